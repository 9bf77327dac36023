"""Group-conditional (Mondrian) conformal quantiles: one quantile per bin of a pixel's variable.

A pooled quantile covers the calibration pixels on average: bins of pixels the scale ranks
less well (close to a measurement, or far from any; near or far) are covered more or less
than asked. Taking the quantile of the normalised residuals per bin of a variable
(:data:`~inpaintenv.values.interval_calibration.CONDITIONS`: the distance in pixels to the
nearest measurement, the predicted depth, the measured share around the pixel) covers each
bin as asked on the calibration frames, under the pooled quantile's weighting (each pixel
alike, or each pixel ``1 / n_k``, ``n_k`` its frame's scored pixels, so that a frame with a
few pixels in a bin does not weigh there as one with many). A bin with fewer than ``min_pixels`` pixels or ``min_frames`` frames
keeps the pooled quantile. The variable is read from the scale's own signal column (the
``border`` signal is ``log(1 + distance)``, ``depth`` ``log(max(pred, 1 m))``, ``density`` the
measured share around the pixel), computed beside the scale's signals when the scale does not
use it (:func:`with_condition`), so a bin is the same at calibration and at prediction. The
scale model is unchanged.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from inpaintenv.exceptions import InvalidInputError
from inpaintenv.values.interval_calibration import (CELL_LEVELS, CONDITION_VERSION, CONDITIONS, DEFAULT_EDGES,
                                                    N_LEVELS)

from ._calibration import check_enough_pixels, residual_quantiles, weighted_quantiles

__all__ = ["MIN_CELL_FRAMES", "MIN_CELL_PIXELS", "cell_of", "cell_quantiles", "check_condition", "check_edges",
           "fit_condition", "stored_quantile", "with_condition"]

#: Fewest pixels and frames a bin needs for a quantile of its own.
MIN_CELL_PIXELS, MIN_CELL_FRAMES = 2000, 10


def with_condition(signals: Sequence[str], variable: str | None) -> tuple[str, ...]:
    """``signals`` and, after them, the signal ``variable`` is read from when the scale does not use it."""
    extra = CONDITIONS.get(variable) if variable is not None else None
    return tuple(signals) + ((extra,) if extra is not None and extra not in signals else ())


def check_condition(condition: Any, edges: Any) -> tuple[float, ...] | None:
    """The bin edges of ``condition`` (None: no conditioning), or one error naming the problem."""
    if condition is None:
        if edges is not None:
            raise InvalidInputError("condition_edges need a condition ('distance' or 'depth')")
        return None
    if condition not in CONDITIONS:
        raise InvalidInputError(f"condition must be None or one of {tuple(CONDITIONS)}, got {condition!r}")
    return DEFAULT_EDGES[condition] if edges is None else check_edges(edges)


def check_edges(edges: Any) -> tuple[float, ...]:
    """``condition_edges``: increasing positive finite numbers, as a tuple of floats."""
    try:
        out = np.asarray(edges, dtype=np.float64)
    except (TypeError, ValueError):
        out = np.empty(0)
    if isinstance(edges, (str, bytes)) or out.ndim != 1 or out.size == 0 or not np.isfinite(out).all() \
            or (out <= 0).any() or (np.diff(out) <= 0).any():
        raise InvalidInputError(f"condition_edges must be increasing positive finite numbers, got {edges!r:.80}")
    return tuple(float(e) for e in out)


def _values(variable: str, signals: Sequence[str], F: np.ndarray) -> np.ndarray:
    """The variable of each row of the design matrix ``F`` (intercept first), from its signal's column."""
    col = F[:, 1 + list(signals).index(CONDITIONS[variable])]
    return np.expm1(col) if variable == "distance" else np.exp(col) if variable == "depth" else col


def cell_of(condition: dict[str, Any], signals: Sequence[str], F: np.ndarray) -> np.ndarray:
    """The bin of each row of ``F``: ``b`` where ``edges[b-1] < value <= edges[b]``."""
    # A hair of slack: log1p/expm1 of an integer distance must land in the bin of the integer.
    edges = np.asarray(condition["edges"], dtype=np.float64) * (1 + 1e-9)
    return np.searchsorted(edges, _values(condition["variable"], signals, F), side="left")


def fit_condition(variable: str, edges: Sequence[float], signals: Sequence[str], F: np.ndarray, normed: np.ndarray,
                  frame: np.ndarray, weighting: str, coverage: float) -> dict[str, Any]:
    """The file's ``condition`` field: each bin's counts and, with enough of them, its quantiles."""
    check_enough_pixels(normed.size, coverage)
    doc: dict[str, Any] = {"version": CONDITION_VERSION, "variable": variable, "edges": [float(e) for e in edges],
                           "min_pixels": MIN_CELL_PIXELS, "min_frames": MIN_CELL_FRAMES, "bins": []}
    cells = cell_of(doc, signals, F)
    weights = 1.0 / np.bincount(frame)[frame]  # the pooled frame weighting's, kept within each bin
    levels = np.append(np.linspace(0.0, 1.0, CELL_LEVELS), coverage)
    for b in range(len(edges) + 1):
        inside = cells == b
        n, frames = int(inside.sum()), int(np.unique(frame[inside]).size)
        cell: dict[str, Any] = {"n_pixels": n, "n_frames": frames, "quantile": None, "residual_quantiles": None}
        if n >= MIN_CELL_PIXELS and frames >= MIN_CELL_FRAMES and math.ceil((n + 1) * coverage) <= n:
            if weighting == "pixel":
                stored, q = residual_quantiles(normed[inside], frame[inside], weighting, coverage)
                stored = stored[::(N_LEVELS - 1) // (CELL_LEVELS - 1)]
            else:
                *stored, q = weighted_quantiles(normed[inside], weights[inside], levels)
            cell.update(quantile=max(float(q), 1e-6), residual_quantiles=[float(v) for v in stored])
        doc["bins"].append(cell)
    return doc


def stored_quantile(stored: np.ndarray, n: int, coverage: float, weighting: str) -> float:
    """``q`` of ``coverage`` read from quantiles stored at evenly spaced levels (conservative).

    The level is the coverage under the frame weighting, ``ceil((n + 1) c) / n`` under the
    pixel weighting (its finite-sample correction); the next stored level at or above it.
    """
    level = coverage if weighting == "frame" else math.ceil((n + 1) * coverage) / n
    if level > 1:
        raise InvalidInputError(f"{n} calibration pixels are too few for a {coverage:g} interval")
    idx = min(len(stored) - 1, math.ceil(level * (len(stored) - 1) - 1e-9))
    return max(float(stored[idx]), 1e-6)


def cell_quantiles(condition: dict[str, Any], pooled: float, coverage: float, calibrated: bool,
                   weighting: str) -> np.ndarray:
    """Each bin's ``q`` at ``coverage`` (``pooled``, the pooled one, where a bin has none);
    exact at the calibrated coverage (``calibrated``)."""
    out = []
    for cell in condition["bins"]:
        if cell["quantile"] is None:
            out.append(pooled)
        elif calibrated:
            out.append(float(cell["quantile"]))
        else:
            out.append(stored_quantile(np.asarray(cell["residual_quantiles"]), cell["n_pixels"], coverage, weighting))
    return np.asarray(out, dtype=np.float64)
