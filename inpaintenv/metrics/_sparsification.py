"""Uncertainty the field compares: sparsification curves, AUSE, AURG, calibration and AUCE.

**Sparsification** (Ilg et al. 2018): rank the scored pixels by the method's uncertainty
(its interval's width, or its ``std``), remove the most uncertain fraction ``r`` and
measure the error (RMSE or MAE) of the pixels kept, for ``r`` on :data:`REMOVED`
(0, 0.02, ..., 0.98). The **oracle** curve removes pixels by their own absolute error (the
lowest any ranking reaches); **random** removal keeps the error where it started (in
expectation: a constant curve). Ties of uncertainty are removed together *in proportion*
(each tied pixel weighs the share of its group the cut takes), which is the expectation
over random tie-breaks: a constant uncertainty gives exactly the random curve.

``AUSE`` is the area between the curve and the oracle's, ``AURG`` the area between the
random curve and the curve, both by the trapezoid rule over ``r`` in [0, 0.98]: lower
AUSE and higher AURG are better; an oracle ranking has AUSE 0, a ranking by *decreasing*
error the largest AUSE any ranking has.

Two conventions, named in every output:

``"pooled"`` (pNCNN, Eldesokey et al. 2020)
    Every scored pixel of every frame pooled into one ranking, and the curves divided by
    their starting value (the error with every pixel kept), so AUSE is unit-free
    (pNCNN's 0.052 on KITTI's validation set is RMSE-based in this convention).
``"per_image"`` (Poggi et al. 2020)
    Each frame ranked alone, AUSE and AURG computed per frame on the unnormalised curves
    (metres), then averaged over frames.

**Calibration**: the coverage (share of truths inside the interval) at the nominal levels
:data:`CALIBRATION_LEVELS` (0.5 to 0.95); ``AUCE`` is the area between the reliability
diagram and the diagonal over them, ``∫ |coverage(c) - c| dc`` by the trapezoid rule on
[0.5, 0.95] (0 = calibrated, at most 0.45; lower is better). Pooled: each pixel alike; per
image: per frame, then averaged.
"""

from __future__ import annotations

import math

import numpy as np

from ..exceptions import InvalidInputError
from ._intervals import Coverage
from ._records import FrameBatch, Metric, register_metric

__all__ = ["CALIBRATION_LEVELS", "CONVENTIONS", "REMOVED", "auce", "calibration", "sparsification"]

#: Fractions of the most uncertain pixels removed: 0, 0.02, ..., 0.98.
REMOVED: tuple[float, ...] = tuple(round(0.02 * k, 2) for k in range(50))
#: Nominal coverages of the reliability diagram and AUCE (checked once, here).
CALIBRATION_LEVELS: tuple[Coverage, ...] = tuple(Coverage(c) for c in (0.5, 0.6, 0.7, 0.8, 0.9, 0.95))
#: The two conventions (see the module docstring).
CONVENTIONS = ("pooled", "per_image")


def _kept_means(values: np.ndarray, score: np.ndarray, segment: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """Mean of each column of ``values`` over the ``keep`` share of each segment's pixels of smallest ``score``.

    ``values`` is ``(P, M)`` (one column per error: squared and absolute share the sort);
    one sort for every segment (``segment``: 0..S-1 per pixel); ties of score within a
    segment are kept in proportion. Returns ``(M, S, len(keep))``, NaN for an empty segment.
    """
    n_seg = int(segment.max()) + 1 if segment.size else 0
    out = np.full((values.shape[1], n_seg, keep.size), np.nan)
    if not segment.size:
        return out
    order = np.lexsort((score, segment))
    s, v, g = score[order], values[order].astype(np.float64), segment[order]
    n = len(v)
    new = np.ones(n, dtype=bool)
    new[1:] = (s[1:] != s[:-1]) | (g[1:] != g[:-1])
    g_start = np.flatnonzero(new)  # tie groups: runs of one score within one segment
    g_size = np.diff(np.append(g_start, n))
    cum = np.concatenate((np.zeros((1, v.shape[1])), np.cumsum(v, axis=0)))
    g_mean = (cum[g_start + g_size] - cum[g_start]) / g_size[:, None]
    counts = np.bincount(g, minlength=n_seg)
    starts = np.concatenate(([0], np.cumsum(counts)[:-1]))
    present = counts > 0
    k = keep[None, :] * counts[present, None]  # pixels kept per segment, a real number
    first = starts[present, None]
    last = first + np.maximum(np.ceil(k - 1e-9).astype(np.int64), 1) - 1  # the last pixel kept
    grp = np.searchsorted(g_start, last, side="right") - 1
    for j in range(v.shape[1]):
        total = cum[g_start[grp], j] - cum[first, j] + (first + k - g_start[grp]) * g_mean[grp, j]
        out[j, present] = total / k
    return out


def sparsification(pred: np.ndarray, gt: np.ndarray, uncertainty: np.ndarray, scored: np.ndarray,
                   convention: str = "pooled", metric: str = "rmse") -> dict[str, np.ndarray | float]:
    """Sparsification curves, AUSE and AURG of one ranking, in one convention.

    Parameters
    ----------
    pred, gt, uncertainty : numpy.ndarray
        ``(H, W)`` or ``(N, H, W)``: prediction and truth (metres, ``gt`` 0 = none) and the
        method's uncertainty (larger = less sure: an interval's width or a ``std``).
    scored : numpy.ndarray
        Boolean, the task's pixels; scored where ``scored & (gt > 0)``.
    convention : {"pooled", "per_image"}
        See the module docstring.
    metric : {"rmse", "mae"}
        The error of the pixels kept.

    Returns
    -------
    dict
        ``removed`` (:data:`REMOVED`), ``curve``, ``oracle`` and ``random`` (``(N, 50)`` per
        image in metres, ``(50,)`` pooled and divided by the start), ``ause`` and ``aurg``
        (``(N,)`` per image, NaN for a frame without scored pixels; a float pooled), and
        ``convention``.
    """
    if convention not in CONVENTIONS:
        raise InvalidInputError(f"convention must be one of {CONVENTIONS}, got {convention!r}")
    if metric not in ("rmse", "mae"):
        raise InvalidInputError(f"metric must be 'rmse' or 'mae', got {metric!r}")
    gt = np.asarray(gt)
    arrays = [np.asarray(a) for a in (pred, uncertainty, scored)]
    if any(a.shape != gt.shape for a in arrays):
        raise InvalidInputError(f"pred, uncertainty and scored must have the truth's shape {gt.shape}")
    frames = gt.reshape(-1, *gt.shape[-2:]) if gt.ndim >= 2 else gt[None, None]
    pred_f, unc_f, scored_f = (a.reshape(frames.shape) for a in arrays)
    return _both(pred_f, frames, unc_f, scored_f, convention)[metric]


def _both(pred: np.ndarray, gt: np.ndarray, unc: np.ndarray, scored: np.ndarray,
          convention: str) -> dict[str, dict[str, np.ndarray | float | str]]:
    """:func:`sparsification` of ``(N, H, W)`` arrays for RMSE and MAE at once (one sort per ranking)."""
    valid = scored.astype(bool) & (gt > 0)
    frame = np.nonzero(valid)[0]
    err = np.abs(pred[valid].astype(np.float64) - gt[valid].astype(np.float64))
    u = unc[valid].astype(np.float64)
    segment = frame if convention == "per_image" else np.zeros_like(frame)
    n_seg = len(gt) if convention == "per_image" else 1
    keep = 1.0 - np.asarray(REMOVED)
    removed = np.asarray(REMOVED)
    kept = {}
    for name, score in (("curve", u), ("oracle", err)):
        means = _kept_means(np.stack([err**2, err], axis=1), score, segment, keep)
        full = np.full((2, n_seg, keep.size), np.nan)
        full[:, : means.shape[1]] = means
        kept[name] = {"rmse": np.sqrt(full[0]), "mae": full[1]}
    out = {}
    for metric in ("rmse", "mae"):
        curves = {name: kept[name][metric] for name in ("curve", "oracle")}
        curves["random"] = np.repeat(curves["curve"][:, :1], keep.size, axis=1)  # every subset's expected error
        if convention == "pooled":
            start = curves["curve"][:, :1]
            with np.errstate(divide="ignore", invalid="ignore"):
                curves = {k: np.where(start > 0, v / start, np.nan)[0] for k, v in curves.items()}
        ause = np.trapezoid(curves["curve"] - curves["oracle"], removed, axis=-1)
        aurg = np.trapezoid(curves["random"] - curves["curve"], removed, axis=-1)
        res: dict[str, np.ndarray | float | str] = {"removed": removed, **curves, "convention": convention}
        res["ause"], res["aurg"] = (float(ause), float(aurg)) if convention == "pooled" else (ause, aurg)
        out[metric] = res
    return out


def calibration(gt: np.ndarray, scored: np.ndarray, intervals: dict[float, tuple[np.ndarray, np.ndarray]],
                convention: str = "pooled") -> dict[str, np.ndarray | float | str]:
    """The reliability diagram and AUCE of intervals at several nominal levels, in one convention.

    Parameters
    ----------
    gt, scored : numpy.ndarray
        ``(H, W)`` or ``(N, H, W)`` truth (0 = none) and the task's pixels.
    intervals : dict
        ``{nominal coverage: (low, high)}`` (e.g. ``predict_interval`` at each of
        :data:`CALIBRATION_LEVELS`), increasing levels.
    convention : {"pooled", "per_image"}
        Every pixel alike, or each frame's coverage then the mean over frames.

    Returns
    -------
    dict
        ``levels``, ``coverage`` (``(L,)`` pooled; ``(N, L)`` per image), ``auce`` (a float
        pooled; ``(N,)`` per image) and ``convention``.
    """
    if convention not in CONVENTIONS:
        raise InvalidInputError(f"convention must be one of {CONVENTIONS}, got {convention!r}")
    levels = tuple(sorted(intervals))
    gt = np.asarray(gt).reshape(-1, *np.shape(gt)[-2:])
    valid = np.asarray(scored, bool).reshape(gt.shape) & (gt > 0)
    inside = [valid & (np.reshape(intervals[c][0], gt.shape) <= gt) & (gt <= np.reshape(intervals[c][1], gt.shape))
              for c in levels]
    if convention == "pooled":
        n = valid.sum()
        cov = np.array([i.sum() / n if n else np.nan for i in inside])
        return {"levels": np.asarray(levels), "coverage": cov, "auce": float(auce(cov, levels)),
                "convention": convention}
    n = valid.sum(axis=(1, 2)).astype(np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        cov = np.stack([np.where(n > 0, i.sum(axis=(1, 2)) / n, np.nan) for i in inside], axis=1)
    return {"levels": np.asarray(levels), "coverage": cov, "auce": auce(cov, levels), "convention": convention}


def auce(coverages: np.ndarray, levels: tuple[float, ...] = CALIBRATION_LEVELS) -> np.ndarray:
    """Area between the reliability diagram and the diagonal: ``∫ |coverage(c) - c| dc`` over ``levels`` (trapezoid).

    Parameters
    ----------
    coverages : numpy.ndarray
        ``(..., len(levels))``: the actual coverage at each nominal level (a frame's, or pooled).
    levels : tuple of float
        The nominal levels, increasing (default :data:`CALIBRATION_LEVELS`).

    Returns
    -------
    numpy.ndarray
        ``(...)``: 0 for a perfectly calibrated interval; NaN where a coverage is NaN.
    """
    cov = np.asarray(coverages, dtype=np.float64)
    if cov.shape[-1] != len(levels):
        raise InvalidInputError(f"coverages has {cov.shape[-1]} levels, expected {len(levels)}")
    return np.trapezoid(np.abs(cov - np.asarray(levels)), np.asarray(levels), axis=-1)


# -- the records: per-image (Poggi) figures of the method's interval, one per frame ----------------
def _width(batch: FrameBatch) -> np.ndarray:
    return np.asarray(batch.high, np.float64) - np.asarray(batch.low, np.float64)


def _curves(batch: FrameBatch, metric: str) -> dict:
    if "sparsification" not in batch.cache:
        batch.cache["sparsification"] = _both(batch.pred, batch.gt, _width(batch), batch.scored, "per_image")
    return batch.cache["sparsification"][metric]


def _median_width(batch: FrameBatch) -> np.ndarray:
    valid = batch.scored & (batch.gt > 0)
    width = np.where(valid, _width(batch), np.nan)
    with np.errstate(all="ignore"):
        return np.array([np.nanmedian(w) if v.any() else np.nan for w, v in zip(width, valid)])


def _coverages(batch: FrameBatch) -> np.ndarray:
    """``(N, len(CALIBRATION_LEVELS))``: each frame's coverage at each level."""
    if batch.levels is None:  # an interval of one level only: no diagram
        return np.full((len(batch.pred), len(CALIBRATION_LEVELS)), np.nan)
    if "coverages" not in batch.cache:
        # The scored pixels gathered once (flat indices), then each level's bounds taken there.
        n_frames = len(batch.pred)
        idx = np.flatnonzero((batch.scored & (batch.gt > 0)).reshape(-1))
        frame = idx // (batch.gt.size // n_frames)
        n = np.bincount(frame, minlength=n_frames).astype(np.float64)
        g = batch.gt.reshape(-1)[idx]
        cols = []
        for level in CALIBRATION_LEVELS:
            low, high = (np.asarray(b).reshape(-1)[idx] for b in batch.levels[level])
            inside = np.bincount(frame, (low <= g) & (g <= high), minlength=n_frames)
            cols.append(np.where(n > 0, inside / np.where(n > 0, n, 1), np.nan))
        batch.cache["coverages"] = np.stack(cols, axis=1)
    return batch.cache["coverages"]


def _register() -> None:
    area = (0.0, math.inf)
    for metric, shown in (("rmse", "interval"), ("mae", None)):
        unit = "m"
        register_metric(Metric(
            f"ause_{metric}", f"per image (Poggi): area between the {metric.upper()} sparsification curve ranked by "
            "interval width and the oracle's (m), over 0-98 % removed", "frames", False, unit,
            f"AUSE {metric.upper()} per image (m)", ".3f", *area, group=shown, rank=10,
            compute=lambda b, m=metric: _curves(b, m)["ause"], needs_interval=True))
        register_metric(Metric(
            f"aurg_{metric}", f"per image (Poggi): area between random removal's {metric.upper()} curve and the "
            "curve ranked by interval width (m)", "frames", True, unit,
            f"AURG {metric.upper()} per image (m)", ".3f", -math.inf, math.inf, group=shown, rank=11,
            compute=lambda b, m=metric: _curves(b, m)["aurg"], needs_interval=True))
    register_metric(Metric(
        "hole_interval_width_median", "median high - low over the task's pixels", "frames", False, "m",
        "median interval width (m)", ".2f", *area, group="interval", rank=1, compute=_median_width,
        needs_interval=True))
    for j, level in enumerate(CALIBRATION_LEVELS):
        register_metric(Metric(
            f"coverage_{round(level * 100)}", f"share of the task's truths inside the {level:g} interval", "mean", True,
            "share", f"coverage at {level:.0%}", ".1%", 0.0, 1.0, compute=lambda b, j=j: _coverages(b)[:, j],
            needs_interval=True))
    register_metric(Metric(
        "auce", "per image: area between the reliability diagram (coverage at 0.5 ... 0.95) and the diagonal",
        "frames", False, "", "AUCE per image", ".3f", 0.0, 0.45, group="interval", rank=12,
        compute=lambda b: auce(_coverages(b)), needs_interval=True))


_register()
