"""What an interval calibration may be: every field, and what the numbers imply together.

An interval calibration (``ConformalIntervalInpainter.save``) is data from outside:
``--intervals`` and ``ConformalIntervalInpainter.load`` read files a user was handed, and
each is checked here, by :func:`check_calibration`, before any interval is computed from
it. The first rule broken is one :class:`~inpaintenv.exceptions.InvalidInputError` naming
the file and the field.

Each field, for what calibration can produce:

``coef``
    ``1 + len(signals)`` finite numbers of at most :data:`MAX_ABS_COEF` in size: the least
    squares of ``log(|residual| + RESIDUAL_FLOOR)`` on the log-signals (:data:`SIGNAL_RANGES`).
``residual_quantiles``
    :data:`N_LEVELS` finite, non-negative, non-decreasing numbers (quantiles of a ratio
    of a non-negative residual to a positive scale).
``quantile``
    A positive finite number between the stored quantiles on either side of the
    calibrated coverage (both weightings' levels taken, so a file of either reads).
``n_pixels``, ``n_frames``
    Integers >= 1; ``n_pixels`` enough for the coverage (``ceil((n + 1) c) <= n``), the
    same at the top and in ``calibration``; out-of-fold records add up to them.
``params`` / ``calibration``
    Coverage in (0, 1), known signals without repeats, a known weighting, strings where
    names are, a non-negative integer seed, and the two copies of what was calibrated
    agreeing.
``condition`` (optional; a file without it has one quantile for every pixel)
    Version :data:`CONDITION_VERSION`; a variable of :data:`CONDITIONS`; increasing positive finite ``edges``; one bin more than edges, their pixel counts
    adding up to ``n_pixels``; a bin below ``min_pixels`` or ``min_frames`` has no quantile of its
    own (the pooled one), any other its :data:`CELL_LEVELS` quantiles checked as
    ``residual_quantiles`` and a quantile within :data:`MAX_CELL_RATIO` of the pooled one.

And what they imply together (:func:`implied_scale_problem`), wherever a pixel's signals can
be within a frame the package reads (the scale ``exp(F @ coef)`` at its smallest ``s_min``
and largest ``s_max`` over :data:`SIGNAL_RANGES`):

* The scale was fitted to ``log(|r| + 0.05 m)``, so over the calibration pixels the mean
  of ``log(n + 0.05 m / s)`` is 0 (``n = |r| / s``, the normalised residual the quantiles
  keep). As ``s_min <= s <= s_max``, the mean of ``log(n + 0.05 m / s_max)`` over the
  stored quantiles may not exceed 0, and that of ``log(n + 0.05 m / s_min)`` may not fall
  below it, by more than :data:`FIT_TOLERANCE` (frame weighting, the fit's sample and the
  ``"far"`` balancing move them a little): a scale far below or far above what the
  residuals it normalised can have been (the intercept moved, or the quantiles and the
  coefficients rescaled together) is refused. The 0.05 m in the fit pins the scale in
  metres, which is what makes this a check of the widths.
* A residual is at most :data:`~inpaintenv.conventions.DEPTH_LIMIT`, so the largest
  normalised residual times ``s_min`` may not exceed it.

Widths are not held to a floor such as a depth PNG's step: a fill exact on its
calibration frames (a synthetic street under scanline) honestly calibrates to intervals of
micrometres.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from inpaintenv.conventions import DEPTH_LIMIT
from inpaintenv.exceptions import InvalidInputError
from inpaintenv.files.limits import MAX_FRAME_PIXELS

__all__ = ["CELL_LEVELS", "CONDITION_VERSION", "CONDITIONS", "DEFAULT_EDGES", "MAX_CELL_RATIO", "DEFAULT_SIGNALS", "DEPTH_FLOOR", "DENSITY_WINDOW", "FAR_DISTANCE", "FIT_TOLERANCE", "FORMAT", "MAX_ABS_COEF", "N_LEVELS",
           "RESIDUAL_FLOOR", "SCALE_LOG_RANGE", "SIGNALS", "SIGNAL_RANGES", "SPREAD_FLOOR", "WEIGHTINGS",
           "check_calibration", "implied_scale_problem", "scale_range"]

FORMAT = "inpaintenv-conformal-intervals-v1"
#: The signals a scale model may use (``"far"``: ``estimators.intervals._calibration.features``).
SIGNALS: tuple[str, ...] = ("border", "depth", "spread", "far", "density", "frame_density")
#: The signals a wrapper uses unless told otherwise.
DEFAULT_SIGNALS: tuple[str, ...] = ("border", "depth", "spread")
#: How the calibration pixels weigh in the quantile.
WEIGHTINGS: tuple[str, ...] = ("frame", "pixel")
#: Levels at which the sorted normalised residuals are kept (0, 0.0005, ..., 1).
N_LEVELS = 2001
#: The variables a quantile may be conditioned on (Mondrian conformal), each read from a scale
#: signal: the distance (px) to the nearest measurement, the predicted depth (m), the share of
#: measured pixels around the pixel (``"density"``, :data:`DENSITY_WINDOW`), the frame's measured share
#: in the rows it measured (``"frame_density"``: one value per frame, a LiDAR's density).
CONDITIONS: dict[str, str] = {"distance": "border", "depth": "depth", "density": "density",
                               "frame_density": "frame_density"}
#: The ``condition`` field's version.
CONDITION_VERSION = 1
#: Bin edges of each variable unless told otherwise: bin ``b`` holds ``edges[b-1] < v <= edges[b]``.
DEFAULT_EDGES: dict[str, tuple[float, ...]] = {"distance": (1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0),
                                               "depth": (5.0, 10.0, 20.0, 40.0),
                                               "density": (0.004, 0.008, 0.012, 0.016, 0.024, 0.032, 0.048),
                                               "frame_density": (0.008, 0.011, 0.014, 0.018, 0.024, 0.032)}
#: Side (px) of the square around a pixel whose measured share is the ``"density"`` signal.
DENSITY_WINDOW = 61
#: Levels at which a bin's normalised residuals are kept (0, 0.005, ..., 1).
CELL_LEVELS = 201
#: A bin's quantile is within this factor of the pooled one (the shipped ones are within 3).
MAX_CELL_RATIO = 20.0
#: Largest size of a scale coefficient: the shipped ones are below 4; 20 already makes the
#: scale change by e^20 over one unit of a log-signal.
MAX_ABS_COEF = 20.0
#: Offsets (metres) that keep the logs finite where the residual or the spread is 0.
RESIDUAL_FLOOR, SPREAD_FLOOR, DEPTH_FLOOR = 0.05, 0.1, 1.0
#: Border distance (px) beyond which the ``"far"`` signal grows: kitti-scan-v1's near_distance.
FAR_DISTANCE = 16.0
#: The log-scale is clipped to this range, so one extreme signal never gives a zero or an
#: overflowing width.
SCALE_LOG_RANGE: tuple[float, float] = (-12.0, 8.0)
#: The range of each signal at a hole pixel of any frame the package reads: the log border
#: distance (below a frame's pixel count), the log depth (floored at 1 m, at most the PNG
#: limit), the log spread between two fills, and the far indicator.
SIGNAL_RANGES: dict[str, tuple[float, float]] = {
    "border": (0.0, math.log1p(MAX_FRAME_PIXELS)),
    "depth": (0.0, math.log(DEPTH_LIMIT)),
    "spread": (math.log(SPREAD_FLOOR), math.log(DEPTH_LIMIT + SPREAD_FLOOR)),
    "far": (0.0, 1.0),
    "density": (0.0, 1.0),
    "frame_density": (0.0, 1.0),
}
#: How far above 0 the mean ``log(n + RESIDUAL_FLOOR / s_max)`` of a fitted calibration may be
#: (the shipped ones are at -0.1 to -0.7; a fit puts it at or below 0).
FIT_TOLERANCE = 1.0


class _Checker:
    """The checks of one file; every failure names the file and the field."""

    def __init__(self, where: Any):
        self.where = where

    def fail(self, field: str, rule: str, value: Any) -> InvalidInputError:
        shown = repr(value)
        shown = shown if len(shown) <= 60 else shown[:57] + "..."
        return InvalidInputError(f"{self.where}: {field!r} must be {rule}, got {shown}; not an interval "
                                 "calibration this package wrote (calibrate again)")

    def get(self, doc: dict[str, Any], key: str, field: str) -> Any:
        if key not in doc:
            raise InvalidInputError(f"{self.where}: missing or malformed key {field!r}")
        return doc[key]

    def obj(self, doc: dict[str, Any], key: str, field: str) -> dict[str, Any]:
        value = self.get(doc, key, field)
        if not isinstance(value, dict):
            raise self.fail(field, "a JSON object", value)
        return value

    def text(self, doc: dict[str, Any], key: str, field: str, *, optional: bool = False) -> str | None:
        value = doc.get(key) if optional else self.get(doc, key, field)
        if value is None and optional:
            return None
        if not isinstance(value, str) or not value:
            raise self.fail(field, "a non-empty string", value)
        return value

    def count(self, doc: dict[str, Any], key: str, field: str, low: int = 1) -> int:
        value = self.get(doc, key, field)
        if isinstance(value, bool) or not isinstance(value, int) or value < low:
            raise self.fail(field, f"an integer >= {low}", value)
        return value

    def coverage(self, doc: dict[str, Any], key: str, field: str) -> float:
        value = self.get(doc, key, field)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.0 < value < 1.0:
            raise self.fail(field, "a number in (0, 1)", value)
        return float(value)

    def numbers(self, doc: dict[str, Any], key: str, field: str, length: int) -> np.ndarray:
        value = self.get(doc, key, field)
        if not isinstance(value, list) or len(value) != length \
                or any(isinstance(v, bool) or not isinstance(v, (int, float)) for v in value):
            raise self.fail(field, f"a list of {length} numbers", value)
        out = np.asarray(value, dtype=np.float64)
        if not np.isfinite(out).all():
            raise self.fail(field, f"a list of {length} finite numbers", value)
        return out

    def names(self, doc: dict[str, Any], key: str, field: str) -> list[str]:
        value = self.get(doc, key, field)
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise self.fail(field, "a list of strings", value)
        return value


def _signals(c: _Checker, params: dict[str, Any]) -> list[str]:
    signals = c.names(params, "signals", "params.signals")
    if any(s not in SIGNALS for s in signals) or len(set(signals)) != len(signals):
        raise c.fail("params.signals", f"distinct names from {SIGNALS}", signals)
    return signals


def _check_params(c: _Checker, doc: dict[str, Any]) -> dict[str, Any]:
    params = c.obj(doc, "params", "params")
    c.coverage(params, "coverage", "params.coverage")
    _signals(c, params)
    c.text(params, "spread_method", "params.spread_method")
    c.text(params, "protocol", "params.protocol")
    c.count(params, "seed", "params.seed", low=0)
    c.count(params, "max_fit_pixels", "params.max_fit_pixels", low=10)
    if params.get("weighting", "pixel") not in WEIGHTINGS:
        raise c.fail("params.weighting", f"one of {WEIGHTINGS}", params.get("weighting"))
    return params


def _check_record(c: _Checker, cal: dict[str, Any], params: dict[str, Any], n_pixels: int) -> None:
    """``calibration``: what was calibrated, agreeing with ``params`` and the top-level counts."""
    c.names(cal, "drives", "calibration.drives")
    n_frames = c.count(cal, "n_frames", "calibration.n_frames")
    if c.count(cal, "n_pixels", "calibration.n_pixels") != n_pixels:
        raise c.fail("calibration.n_pixels", f"the top-level n_pixels ({n_pixels})", cal["n_pixels"])
    for key, field in (("coverage", "coverage"), ("signals", "signals"), ("protocol", "protocol"), ("seed", "seed")):
        if c.get(cal, key, f"calibration.{field}") != params[key]:
            raise c.fail(f"calibration.{field}", f"params.{field} ({params[key]!r})", cal[key])
    if cal.get("weighting", params.get("weighting", "pixel")) != params.get("weighting", "pixel"):
        raise c.fail("calibration.weighting", f"params.weighting ({params.get('weighting', 'pixel')!r})",
                     cal.get("weighting"))
    spread = c.text(cal, "spread_method", "calibration.spread_method", optional=True)
    if ("spread" in params["signals"]) != (spread is not None) or spread not in (None, params["spread_method"]):
        raise c.fail("calibration.spread_method", "params.spread_method with the 'spread' signal, else null", spread)
    c.text(cal, "base", "calibration.base")
    folds = cal.get("out_of_fold")
    if folds is None:
        return
    if not isinstance(folds, list) or not folds or not all(isinstance(f, dict) for f in folds):
        raise c.fail("calibration.out_of_fold", "a non-empty list of JSON objects", folds)
    for k, fold in enumerate(folds):
        c.names(fold, "drives", f"calibration.out_of_fold[{k}].drives")
        c.names(fold, "training_drives", f"calibration.out_of_fold[{k}].training_drives")
    for key, total in (("n_frames", n_frames), ("n_pixels", n_pixels)):
        parts = [c.count(f, key, f"calibration.out_of_fold[{k}].{key}") for k, f in enumerate(folds)]
        if sum(parts) != total:
            raise c.fail(f"calibration.out_of_fold[*].{key}", f"counts adding up to calibration.{key} ({total})",
                         parts)


def _check_quantiles(c: _Checker, doc: dict[str, Any], coverage: float, n_pixels: int, where: str = "",
                     n_levels: int = N_LEVELS) -> None:
    """``residual_quantiles`` non-negative and non-decreasing; ``quantile`` positive and between
    the stored quantiles on either side of the coverage (``where``: the fields' prefix)."""
    stored = c.numbers(doc, "residual_quantiles", f"{where}residual_quantiles", n_levels)
    if stored[0] < 0 or (np.diff(stored) < 0).any():
        raise c.fail(f"{where}residual_quantiles", "non-negative and non-decreasing (quantiles of |residual| / scale)",
                     doc["residual_quantiles"])
    q = doc.get("quantile")
    if isinstance(q, bool) or not isinstance(q, (int, float)) or not math.isfinite(q) or q <= 0:
        raise c.fail(f"{where}quantile", "a positive finite number", q)
    if math.ceil((n_pixels + 1) * coverage) > n_pixels:
        raise c.fail(f"{where}n_pixels", f"enough pixels for a {coverage:g} interval "
                     f"(>= {math.ceil(coverage / (1 - coverage))})", n_pixels)
    # The level of q under either weighting: the frame weighting's is the coverage, the
    # pixel weighting's the rank ceil((n + 1) c) among n.
    rank = (math.ceil((n_pixels + 1) * coverage) - 1) / max(n_pixels - 1, 1)
    levels = [coverage * (n_levels - 1), rank * (n_levels - 1)]
    lo = stored[max(0, math.floor(min(levels)) - 1)]
    hi = max(float(stored[min(n_levels - 1, math.ceil(max(levels)) + 1)]), 1e-6)
    if not lo * (1 - 1e-9) <= q <= hi * (1 + 1e-9):
        raise c.fail(f"{where}quantile", f"between the stored residual quantiles at the coverage ({lo:.6g} .. {hi:.6g})",
                     q)


def _check_condition(c: _Checker, doc: dict[str, Any], params: dict[str, Any], n_pixels: int) -> None:
    """``condition``: the quantile per bin of a variable (absent: one quantile for every pixel)."""
    if "condition" not in doc:
        return
    cond = c.obj(doc, "condition", "condition")
    if cond.get("version") != CONDITION_VERSION:
        raise c.fail("condition.version", f"{CONDITION_VERSION}", cond.get("version"))
    variable = cond.get("variable")
    if variable not in CONDITIONS:
        raise c.fail("condition.variable", f"one of {tuple(CONDITIONS)}", variable)
    raw = cond.get("edges")
    edges = c.numbers(cond, "edges", "condition.edges", len(raw) if isinstance(raw, list) and raw else 1)
    if (edges <= 0).any() or (np.diff(edges) <= 0).any():
        raise c.fail("condition.edges", "increasing positive numbers", raw)
    min_pixels = c.count(cond, "min_pixels", "condition.min_pixels")
    min_frames = c.count(cond, "min_frames", "condition.min_frames")
    bins = c.get(cond, "bins", "condition.bins")
    if not isinstance(bins, list) or len(bins) != len(edges) + 1 or not all(isinstance(b, dict) for b in bins):
        raise c.fail("condition.bins", f"a list of {len(edges) + 1} JSON objects (one more than edges)", bins)
    coverage, pooled = float(params["coverage"]), float(doc["quantile"])
    for k, cell in enumerate(bins):
        where = f"condition.bins[{k}]."
        n, frames = c.count(cell, "n_pixels", where + "n_pixels", low=0), c.count(cell, "n_frames", where + "n_frames", low=0)
        few = n < min_pixels or frames < min_frames
        if cell.get("quantile") is None or cell.get("residual_quantiles") is None:
            if not few or cell.get("quantile") is not None or cell.get("residual_quantiles") is not None:
                raise c.fail(where + "quantile", f"null with residual_quantiles (the pooled quantile) exactly when "
                             f"the bin has under {min_pixels} pixels or {min_frames} frames", cell.get("quantile"))
            continue
        if few:
            raise c.fail(where + "quantile", f"null (the bin has under {min_pixels} pixels or {min_frames} frames)",
                         cell["quantile"])
        _check_quantiles(c, cell, coverage, n, where, CELL_LEVELS)
        if not 1 / MAX_CELL_RATIO <= cell["quantile"] / pooled <= MAX_CELL_RATIO:
            raise c.fail(where + "quantile", f"within {MAX_CELL_RATIO:g}x of the pooled quantile ({pooled:.4g})",
                         cell["quantile"])
        if float(cell["residual_quantiles"][-1]) * scale_range(np.asarray(doc["coef"], float), params["signals"])[0] \
                > DEPTH_LIMIT:
            raise c.fail(where + "residual_quantiles", f"residuals of at most {DEPTH_LIMIT:.3f} m", cell["quantile"])
    counts = [cell["n_pixels"] for cell in bins]
    if sum(counts) != n_pixels:
        raise c.fail("condition.bins[*].n_pixels", f"counts adding up to n_pixels ({n_pixels})", counts)


def check_calibration(doc: Any, where: Any) -> dict[str, Any]:
    """``doc`` if it is an interval calibration every field of which can mean what it says.

    Raises
    ------
    InvalidInputError
        Naming ``where`` and the first field that breaks its rule (see the module docstring).
    """
    c = _Checker(where)
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise InvalidInputError(f"{where}: 'format' must be {FORMAT!r}")
    c.text(doc, "base", "base")
    c.text(doc, "base_class", "base_class")
    params = _check_params(c, doc)
    coef = c.numbers(doc, "coef", "coef", 1 + len(params["signals"]))
    if (np.abs(coef) > MAX_ABS_COEF).any():
        raise c.fail("coef", f"numbers of at most {MAX_ABS_COEF:g} in size (a scale's log-linear coefficients)",
                     doc["coef"])
    n_pixels = c.count(doc, "n_pixels", "n_pixels")
    _check_record(c, c.obj(doc, "calibration", "calibration"), params, n_pixels)
    _check_quantiles(c, doc, float(params["coverage"]), n_pixels)
    _check_condition(c, doc, params, n_pixels)
    problem = implied_scale_problem(coef, params["signals"], np.asarray(doc["residual_quantiles"], dtype=np.float64))
    if problem is not None:
        raise c.fail(*problem)
    return doc


def scale_range(coef: np.ndarray, signals: list[str] | tuple[str, ...]) -> tuple[float, float]:
    """The smallest and largest scale (metres) ``coef`` gives over :data:`SIGNAL_RANGES`, clipped as
    ``scale_from`` clips it."""
    lo = hi = float(coef[0])
    for c, s in zip(coef[1:], signals):
        a, b = (float(c) * v for v in SIGNAL_RANGES[s])
        lo, hi = lo + min(a, b), hi + max(a, b)
    low, high = SCALE_LOG_RANGE
    return math.exp(min(max(lo, low), high)), math.exp(min(max(hi, low), high))


def _mean_log(stored: np.ndarray, log_scale: float) -> float:
    """The mean of ``log(n + RESIDUAL_FLOOR / s)`` over the stored quantiles ``n`` at one scale ``s``."""
    return float(np.mean(np.log(stored + RESIDUAL_FLOOR / math.exp(log_scale))))


def _scale_where(stored: np.ndarray, target: float) -> float:
    """The scale (metres) at which :func:`_mean_log` is ``target`` (it falls as the scale grows)."""
    lo, hi = -60.0, 60.0
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if _mean_log(stored, mid) > target else (lo, mid)
    return math.exp(hi)


def implied_scale_problem(coef: np.ndarray, signals: list[str] | tuple[str, ...],
                          stored: np.ndarray) -> tuple[str, str, Any] | None:
    """``(field, rule, value)`` of the first way the scale coefficients ``coef`` and the stored
    normalised residual quantiles ``stored`` cannot belong together (see the module docstring), or None."""
    s_min, s_max = scale_range(coef, signals)
    fit = f"a fit of log(|residual| + {RESIDUAL_FLOOR:g} m) with these residual_quantiles needs it"
    shown = [float(c) for c in coef]
    if _mean_log(stored, math.log(s_max)) > FIT_TOLERANCE:
        return ("coef", f"a scale that reaches at least {_scale_where(stored, FIT_TOLERANCE):.3g} m somewhere ({fit}); "
                f"it is at most {s_max:.3g} m at any pixel", shown)
    if _mean_log(stored, math.log(s_min)) < -FIT_TOLERANCE:
        return ("coef", f"a scale that falls to at most {_scale_where(stored, -FIT_TOLERANCE):.3g} m somewhere ({fit}); "
                f"it is at least {s_min:.3g} m at every pixel", shown)
    if float(stored[-1]) * s_min > DEPTH_LIMIT:
        return ("coef", f"a scale under which the largest normalised residual ({float(stored[-1]):.4g}) is a residual "
                f"of at most {DEPTH_LIMIT:.3f} m; it is at least {s_min:.3g} m at every pixel", shown)
    return None
