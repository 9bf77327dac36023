"""The calibration maths of :class:`~estimators.intervals.ConformalIntervalInpainter`.

The scored pixels' signals and residuals, the log-linear scale fitted on them, and the
(weighted) quantiles of the normalised residuals; the module docstring of
``estimators.intervals._conformal`` says what each is for.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from inpaintenv.data.base import DepthDataset
from inpaintenv.exceptions import InvalidInputError
from inpaintenv.metrics import border_distance

from ..base import iter_scoring_batches
from ._calibration_file import N_LEVELS

__all__ = ["check_enough_pixels", "exact_quantile", "features", "fit_scale", "residual_quantiles", "scale_from",
           "scored_residuals", "weighted_quantiles"]

#: Offsets (metres) that keep the logs finite where the residual or the spread is 0.
RESIDUAL_FLOOR, SPREAD_FLOOR, DEPTH_FLOOR = 0.05, 0.1, 1.0


def features(signals: Sequence[str], pred: np.ndarray, hole: np.ndarray, second: np.ndarray | None) -> np.ndarray:
    """``(n_hole_pixels, 1 + len(signals))`` design matrix of the hole pixels (intercept first)."""
    cols = [np.ones(int(hole.sum()))]
    for s in signals:
        if s == "border":
            cols.append(np.log1p(border_distance(hole)[hole].astype(np.float64)))
        elif s == "depth":
            cols.append(np.log(np.maximum(pred[hole].astype(np.float64), DEPTH_FLOOR)))
        else:  # spread
            cols.append(np.log(np.abs(pred[hole].astype(np.float64) - second[hole]) + SPREAD_FLOOR))
    return np.stack(cols, axis=1)


def weighted_quantiles(values: np.ndarray, weights: np.ndarray, levels: Sequence[float]) -> np.ndarray:
    """The smallest ``v`` of ``values`` whose weighted share at or below it reaches each level.

    With equal weights this is ``np.quantile(values, levels, method="inverted_cdf")``.
    """
    order = np.argsort(values)  # ties need no stable order: tied values are the same value
    cdf = np.cumsum(weights[order], dtype=np.float64)
    cdf /= cdf[-1]
    # A level hit up to rounding must not step to the next value.
    idx = np.searchsorted(cdf, np.asarray(levels, dtype=np.float64) - 1e-12, side="left")
    return values[order[np.minimum(idx, len(order) - 1)]]


def scored_residuals(model: Any, dataset: DepthDataset, signals: tuple[str, ...], second: Any, protocol: str,
                     seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The signals (design matrix), absolute residuals and frame number of ``model``'s every scored pixel.

    The scored pixels are :func:`estimators.base.iter_scoring_batches`': the hole of a map,
    every pixel a single scan leaves to fill.
    """
    feats, resid, frame = [], [], []
    start = 0
    for x, gt, hole in iter_scoring_batches(dataset, protocol=protocol, seed=seed):
        pred = np.asarray(model.predict(x), dtype=np.float32)
        other = np.asarray(second.predict(x), dtype=np.float64) if second is not None else None
        for k in range(len(x)):
            scored = hole[k] & (gt[k] > 0)
            if not scored.any():
                continue
            f = features(signals, pred[k], hole[k], None if other is None else other[k])
            feats.append(f[scored[hole[k]]])
            resid.append(np.abs(gt[k][scored].astype(np.float64) - pred[k][scored]))
            frame.append(np.full(resid[-1].size, start + k, dtype=np.int64))
        start += len(x)
    if not resid:
        raise InvalidInputError("no calibration frame has ground truth inside its holes; nothing to calibrate on")
    return np.concatenate(feats), np.concatenate(resid), np.concatenate(frame)


def fit_scale(F: np.ndarray, r: np.ndarray, seed: int, max_fit_pixels: int) -> np.ndarray:
    """Least squares of ``log(r + 0.05 m)`` on ``F``, on at most ``max_fit_pixels`` pixels drawn with ``seed``."""
    rng = np.random.default_rng(int(seed))
    take = rng.choice(len(r), max_fit_pixels, replace=False) if len(r) > max_fit_pixels else slice(None)
    coef, *_ = np.linalg.lstsq(F[take], np.log(r[take] + RESIDUAL_FLOOR), rcond=None)
    return coef


def scale_from(coef: np.ndarray, F: np.ndarray) -> np.ndarray:
    """The scale (metres) of each row of ``F``."""
    # Clipped so that one extreme signal never gives a zero or an overflowing width.
    return np.exp(np.clip(F @ coef, -12.0, 8.0))


def check_enough_pixels(n: int, coverage: float) -> int:
    """The rank ``ceil((n + 1) c)`` of the split-conformal quantile; refused when it exceeds ``n``."""
    k = math.ceil((n + 1) * coverage)
    if k > n:
        raise InvalidInputError(f"{n} calibration pixels are too few for a {coverage:g} interval (needs "
                                f"{math.ceil(coverage / (1 - coverage))})")
    return k


def exact_quantile(sorted_normed: np.ndarray, coverage: float) -> float:
    """The split-conformal quantile: the ``ceil((n + 1) c)``-th smallest of the sorted normalised residuals."""
    k = check_enough_pixels(sorted_normed.size, coverage)
    return max(float(sorted_normed[k - 1]), 1e-6)


def residual_quantiles(normed: np.ndarray, frame: np.ndarray, weighting: str,
                       coverage: float) -> tuple[np.ndarray, float]:
    """The normalised residuals' quantiles at :data:`N_LEVELS` levels, and ``q`` at ``coverage``.

    ``"pixel"``: every pixel alike, ``q`` the exact order statistic; ``"frame"``: each
    frame's pixels weigh ``1 / n_k`` (``frame`` numbers the frames).
    """
    levels = np.linspace(0.0, 1.0, N_LEVELS)
    if weighting == "pixel":
        ordered = np.sort(normed)  # one sort for both: np.quantile(..., method="higher") reads these indices
        return ordered[np.ceil(levels * (ordered.size - 1)).astype(np.int64)], exact_quantile(ordered, coverage)
    check_enough_pixels(normed.size, coverage)  # refused as the pixel weighting is
    per_frame = np.bincount(frame)  # frame numbers are small non-negative integers
    found = weighted_quantiles(normed, 1.0 / per_frame[frame], np.append(levels, coverage))
    return found[:-1], max(float(found[-1]), 1e-6)
