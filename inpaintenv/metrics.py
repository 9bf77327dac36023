"""Depth-inpainting metrics on valid ground truth: inside the holes and over all pixels.

Only pixels with ground truth (``gt > 0``) count: ``S = gt > 0``; hole metrics use
``S ∩ H``, global ("all") metrics use ``S``. Per frame we report RMSE and MAE in metres,
iRMSE and iMAE in 1/km (KITTI devkit), and PSNR = ``20·log10(max_depth / RMSE)`` in dB.
Aggregation is the mean over frames (the study's convention) or, on request, pooled
over pixels. A frame whose hole holds no valid ground truth has NaN hole metrics, is
counted in ``n_skipped_hole`` and enters no mean (neither hole nor all: it tested
nothing, and its all-pixel error would be ~0 with a PSNR of ~158 dB), so the hole and
all-pixel columns describe the same frames.

The KITTI devkit (``evaluate_depth.cpp``) differs in three ways. Its per-frame formulas
are these (equal in float64), but it averages *every* frame
(``aggregate(..., all_frames="every")`` gives that mean). It reports m and 1/m; we report
m and 1/km for iRMSE/iMAE (the leaderboard: mm and 1/km). And it inverts the prediction
as is, after filling unfilled (0) pixels by its background interpolation; we clamp the
prediction to :data:`MIN_INVERSE_DEPTH` (0.1 m) before inverting, so a prediction near
0 m gives a large finite inverse error instead of inf.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping

import numpy as np

from .conventions import (
    DEFAULT_MAX_DEPTH,
    as_depth_array,
    check_depth,
    check_mask,
    check_max_depth,
    reconstruction_problem,
)
from .exceptions import InvalidInputError, UnfilledPixelsError, UnknownNameError

__all__ = [
    "DEPTH_BIN_EDGES", "METRIC_NAMES", "REGIONS", "UNFILLED", "ScoredPixels", "UnfilledPixelsError", "aggregate",
    "check_unfilled", "depth_binned_errors", "frame_metrics", "interpolate_background",
]

REGIONS = ("hole", "all")
METRIC_NAMES = ("rmse", "mae", "irmse", "imae", "psnr")
#: Predictions are clipped to this depth before inversion (iRMSE/iMAE), so an unfilled
#: pixel (0 m) gives a large but finite error instead of inf.
MIN_INVERSE_DEPTH = 0.1
#: RMSE floor for PSNR, so a perfect frame gives a large finite value, not inf.
MIN_PSNR_RMSE = 1e-6
#: Default true-depth bins (metres) of :func:`depth_binned_errors`.
DEPTH_BIN_EDGES = (0.0, 10.0, 20.0, 30.0, 50.0, np.inf)
#: How a prediction left at 0 m (unfilled) where ground truth exists is scored:
#: ``"error"`` refuses it in the hole (the default), ``"interpolate"`` fills such pixels first by the
#: KITTI devkit's background interpolation (:func:`interpolate_background`), ``"zero"``
#: scores them as 0 m (how the study scored its hole-only baselines).
UNFILLED = ("error", "interpolate", "zero")


def check_unfilled(value: object, name: str = "unfilled") -> str:
    """``value`` if it is one of :data:`UNFILLED`, else a ValueError listing them."""
    if not isinstance(value, str) or value not in UNFILLED:
        raise InvalidInputError(f"{name} must be one of {', '.join(map(repr, UNFILLED))}, got {value!r}")
    return value


def interpolate_background(pred: np.ndarray) -> np.ndarray:
    """Fill the unfilled (0 m, or NaN) pixels of a prediction as the KITTI devkit does.

    The devkit (``io_depth.h``, ``interpolateBackground``) runs before it scores a
    prediction. Per row, a run of unfilled pixels between two filled ones takes the
    *smaller* of the two depths (the nearer surface: the rule comes from the devkit's
    disparity code, where the smaller value is the background); runs at the row's ends
    take the nearest filled value. Then, per column, rows still empty (rows without any
    filled pixel) above the first or below the last filled row take that row's value;
    empty rows between filled ones, and frames without any filled pixel, stay 0.

    Parameters
    ----------
    pred : numpy.ndarray
        ``(H, W)`` or ``(N, H, W)`` depth in metres; ``> 0`` is filled.

    Returns
    -------
    numpy.ndarray
        float32 copy of ``pred``'s shape.
    """
    d = np.array(pred, dtype=np.float32)
    frames = d.reshape(-1, *d.shape[-2:])
    h, w = frames.shape[1:]
    rows = frames.reshape(-1, w)  # a view: filled in place
    filled = rows > 0  # NaN > 0 is False: NaN counts as unfilled
    col = np.arange(w)
    left = np.maximum.accumulate(np.where(filled, col, -1), axis=1)  # last filled at or before
    right = np.minimum.accumulate(np.where(filled, col, w)[:, ::-1], axis=1)[:, ::-1]  # next at or after
    r = np.arange(len(rows))[:, None]
    lv, rv = rows[r, np.clip(left, 0, w - 1)], rows[r, np.clip(right, 0, w - 1)]
    has_l, has_r = left >= 0, right < w
    rows[:] = np.where(
        filled, rows,
        np.where(has_l & has_r, np.minimum(lv, rv), np.where(has_l, lv, np.where(has_r, rv, 0.0))),
    )
    # Columns: after the row pass a row is entirely filled or entirely empty.
    full = frames[:, :, 0] > 0  # (N, H)
    has = full.any(axis=1)
    first = np.argmax(full, axis=1)
    last = h - 1 - np.argmax(full[:, ::-1], axis=1)
    n = np.arange(len(frames))
    y = np.arange(h)[None, :]
    source = np.where(y < first[:, None], first[:, None], np.where(y > last[:, None], last[:, None], y))
    source = np.where(has[:, None] & ~full, source, y)  # empty rows inside stay (source = itself)
    frames[:] = frames[n[:, None], source]
    return np.nan_to_num(d, nan=0.0)


def frame_metrics(
    pred: np.ndarray,
    gt: np.ndarray,
    hole: np.ndarray,
    *,
    max_depth: float = DEFAULT_MAX_DEPTH,
    unfilled: str = "error",
) -> dict[str, np.ndarray]:
    """Per-frame metrics for one frame or a batch, vectorised.

    Parameters
    ----------
    pred : numpy.ndarray
        Reconstruction in metres, ``(H, W)`` or ``(N, H, W)``; wherever ground truth
        exists it must be finite, non-negative and at most
        :data:`~inpaintenv.conventions.DEPTH_LIMIT` (255.996 m), as the environment requires.
    gt : numpy.ndarray
        Ground truth of the same shape, 0 = no measurement.
    hole : numpy.ndarray
        Boolean occlusion mask of the same shape.
    max_depth : float
        Range for PSNR (80 m by default).
    unfilled : {"error", "interpolate", "zero"}
        A prediction of 0 m where ground truth exists is unfilled: in the hole it is
        refused with :class:`UnfilledPixelsError` (default; outside the hole, where the
        method was given the measurement, it is scored as given), or every such pixel is
        filled first by the KITTI devkit's :func:`interpolate_background`, or scored as
        0 m (see :data:`UNFILLED`).

    Returns
    -------
    dict of str to numpy.ndarray
        Keys ``{region}_{metric}`` for region in ``("hole", "all")`` and metric in
        ``("rmse", "mae", "irmse", "imae", "psnr")``, plus ``hole_count`` and
        ``all_count`` (number of scored pixels). Each value has shape ``(N,)`` (or is a
        0-d array for a single frame). Hole metrics are NaN where ``hole_count == 0``.
    """
    pred_arr, gt, hole = _check_inputs(pred, gt, hole)
    # NaN/inf would pass a plain "<= 0" test and give NaN/inf PSNR in every row.
    max_depth = check_max_depth(max_depth)
    return ScoredPixels(gt, hole, check_input=False).metrics(pred_arr, max_depth=max_depth, unfilled=unfilled)


class ScoredPixels:
    """The pixels a frame (or batch) is scored on, gathered once: valid ground truth.

    :func:`frame_metrics` builds one per call. Code that serves a frame before it is
    scored (the environment: ``reset`` then ``step``) builds it when the frame is served
    and scores the submission with :meth:`metrics`, so ground truth and hole are
    gathered once and only the prediction is read at scoring time. The numbers are
    :func:`frame_metrics`'s: it runs this very code.

    Parameters
    ----------
    gt : numpy.ndarray
        Ground truth in metres, ``(H, W)`` or ``(N, H, W)``, 0 = no measurement
        (checked with :func:`~inpaintenv.conventions.check_depth`).
    hole : numpy.ndarray
        Boolean (or 0/1) occlusion mask of the same shape.
    check_input : bool, default True
        False skips checking ``gt`` and ``hole``, for callers that have just checked
        them (float32 ground truth from :func:`~inpaintenv.conventions.check_depth`, a
        boolean mask of its shape); unchecked input then gives wrong numbers silently.

    Attributes
    ----------
    shape : tuple of int
        Shape of ``gt``.
    all_count, hole_count : numpy.ndarray
        Scored pixels per frame (``(N,)`` int64, or 0-d for one frame): valid ground
        truth, and valid ground truth inside the hole.
    """

    def __init__(self, gt: np.ndarray, hole: np.ndarray, *, check_input: bool = True):
        if check_input:
            gt = check_depth(gt, name="ground truth")
            hole = check_mask(hole, gt.shape)
        self.shape: tuple[int, ...] = gt.shape
        self._single = gt.ndim == 2
        flat_gt, flat_hole = gt.reshape(-1), hole.reshape(-1)
        # Flat indices from one scan, then cheap takes: boolean-mask gathers rescan the
        # whole frame each time and were most of the cost of scoring a KITTI frame.
        # Flat order walks frames in order: frame k's pixels are one contiguous run.
        self._index = np.flatnonzero(flat_gt > 0)
        self._gt = flat_gt.take(self._index).astype(np.float64)
        self._in_hole = flat_hole.take(self._index)
        # Pixels per frame from where each frame starts in the sorted index (counting
        # along an axis of the full-size mask costs as much as the gather itself).
        n_frames = 1 if self._single else len(gt)
        starts = np.arange(n_frames + 1) * (flat_gt.size // n_frames)
        n_all = np.diff(np.searchsorted(self._index, starts))
        n_hole = np.diff(np.searchsorted(self._index[self._in_hole], starts))
        self.all_count = n_all[0] if self._single else n_all
        self.hole_count = n_hole[0] if self._single else n_hole
        # Per region: pixels per frame, their layout for _frame_sums, and the divisor
        # of the means (NaN for a frame without any: its metrics are NaN).
        self._regions = {
            region: (n, _runs(n), np.where(n > 0, n, np.nan)) for region, n in (("hole", n_hole), ("all", n_all))
        }

    def metrics(
        self, pred: np.ndarray, *, max_depth: float = DEFAULT_MAX_DEPTH, unfilled: str = "error"
    ) -> dict[str, np.ndarray]:
        """The metrics of :func:`frame_metrics` for the prediction ``pred``.

        Parameters
        ----------
        pred : numpy.ndarray
            Reconstruction in metres, of the ground truth's shape; wherever ground truth
            exists it must be finite, non-negative and at most 255.996 m (as in :func:`frame_metrics`).
        max_depth : float
            Range for PSNR (80 m by default).
        unfilled : {"error", "interpolate", "zero"}
            What a prediction of 0 m at a scored pixel means (see :data:`UNFILLED`).

        Returns
        -------
        dict of str to numpy.ndarray
            As :func:`frame_metrics`.

        Raises
        ------
        UnfilledPixelsError
            With ``unfilled="error"``, if ``pred`` is 0 m at a hole pixel with ground truth.
        ValueError
            On a wrong shape, NaN/inf, negative depth or depth above
            :data:`~inpaintenv.conventions.DEPTH_LIMIT` (255.996 m, the environment's bound)
            at a scored pixel, or an invalid ``max_depth`` or ``unfilled``.
        TypeError
            If ``pred`` is not a floating-point array.
        """
        pred_arr = _check_pred(pred, self.shape)
        max_depth = check_max_depth(max_depth)
        check_unfilled(unfilled)
        return self._metrics(pred_arr, _checked_scored(pred_arr.reshape(-1).take(self._index)), max_depth, unfilled)

    def _metrics(self, pred_arr: np.ndarray, p: np.ndarray, max_depth: float, unfilled: str) -> dict[str, np.ndarray]:
        """:meth:`metrics` after its checks: ``p`` is ``pred_arr`` at the scored pixels, float64."""
        if unfilled != "zero" and p.size and p.min() == 0:
            if unfilled == "interpolate":
                # The devkit fills every 0 of the prediction; only 0-m pixels change, so a
                # prediction without any at a scored pixel is left as is.
                p = _checked_scored(interpolate_background(pred_arr).reshape(-1).take(self._index))
            elif n := int(np.count_nonzero((p == 0) & self._in_hole)):
                # Outside the hole the method was given the measurement: 0 there is scored as given.
                raise UnfilledPixelsError(
                    f"prediction is 0 m (unfilled) at {n} hole pixels with ground truth; fill them, or set unfilled "
                    "to 'interpolate' (the KITTI devkit's background interpolation) or 'zero' (score them as 0 m)"
                )
        # The arithmetic stays in float64 on the compact vector of scored pixels, so
        # results match a pixel-by-pixel reference.
        g, in_hole = self._gt, self._in_hole
        err = p - g
        inv_err = 1000.0 / np.maximum(p, MIN_INVERSE_DEPTH) - 1000.0 / g
        out: dict[str, np.ndarray] = {}
        for region in REGIONS:
            n, runs, denom = self._regions[region]
            e, ie = (err, inv_err) if region == "all" else (err[in_hole], inv_err[in_hole])
            rmse = np.sqrt(_frame_sums(e * e, runs) / denom)
            out[f"{region}_rmse"] = rmse
            out[f"{region}_mae"] = _frame_sums(np.abs(e), runs) / denom
            out[f"{region}_irmse"] = np.sqrt(_frame_sums(ie * ie, runs) / denom)
            out[f"{region}_imae"] = _frame_sums(np.abs(ie), runs) / denom
            out[f"{region}_psnr"] = 20.0 * np.log10(max_depth / np.maximum(rmse, MIN_PSNR_RMSE))
            out[f"{region}_count"] = np.asarray(n, dtype=np.int64)
        if self._single:
            out = {k: v[0] for k, v in out.items()}
        return out


def _frame_metrics_checked(
    pred: np.ndarray, gt: np.ndarray, hole: np.ndarray, *, max_depth: float, unfilled: str
) -> dict[str, np.ndarray]:
    """:func:`frame_metrics` of inputs validated where they entered: the private fast path.

    For :func:`inpaintenv.evaluate.evaluate`, whose frames, masks and outputs were checked
    once at its boundary (as scikit-learn's ``skip_parameter_validation``): ``gt`` float32
    from :meth:`~inpaintenv.data.base.DepthDataset.load_batch` (every frame checked by
    :func:`~inpaintenv.conventions.check_depth`), ``hole`` a boolean mask of its shape
    from :meth:`~inpaintenv.masks.OcclusionProtocol.masks`, ``pred`` a finite,
    non-negative float32 array of its shape (``evaluate``'s output check), ``max_depth``
    and ``unfilled`` checked. Nothing is checked again; unchecked input gives wrong
    numbers silently. The numbers are :func:`frame_metrics`'s: the same code scores them.
    """
    scored = ScoredPixels(gt, hole, check_input=False)
    return scored._metrics(pred, pred.reshape(-1).take(scored._index).astype(np.float64), max_depth, unfilled)


def _check_inputs(pred: np.ndarray, gt: np.ndarray, hole: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(pred, gt, hole)`` as arrays after checking ground truth, shapes, dtype and mask."""
    gt = check_depth(gt, name="ground truth")
    return _check_pred(pred, gt.shape), gt, check_mask(hole, gt.shape)


def _check_pred(pred: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """``pred`` as an array after checking its dtype (:func:`~inpaintenv.conventions.as_depth_array`) and shape."""
    pred_arr = as_depth_array(pred, "prediction")
    if pred_arr.shape != shape:
        raise InvalidInputError(f"prediction has shape {pred_arr.shape}, ground truth {shape}")
    return pred_arr


def _checked_scored(scored_pred: np.ndarray) -> np.ndarray:
    """The prediction at scored pixels as float64, refused as the env refuses an action (``reconstruction_problem``)."""
    problem = reconstruction_problem(scored_pred)
    if problem is not None:
        raise InvalidInputError(f"prediction at pixels with ground truth {problem}")
    return scored_pred.astype(np.float64)


def _runs(counts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Layout of values holding ``counts[k]`` consecutive entries of frame k, for :func:`_frame_sums`.

    Returns the start of each non-empty frame's run and the mask of non-empty frames.
    """
    nonempty = counts > 0
    return (np.cumsum(counts) - counts)[nonempty], nonempty


def _frame_sums(values: np.ndarray, runs: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """Per-frame sums of ``values`` laid out as ``runs`` (see :func:`_runs`); 0 for empty frames."""
    starts, nonempty = runs
    out = np.zeros(len(nonempty), dtype=np.float64)
    if starts.size:
        # reduceat sums from each start to the next one; empty frames are left out so
        # their (meaningless) reduceat entries never appear.
        out[nonempty] = np.add.reduceat(values.astype(np.float64, copy=False), starts)
    return out


def aggregate(
    per_frame: Mapping[str, np.ndarray] | list[Mapping[str, float]],
    *,
    how: str = "mean",
    max_depth: float = DEFAULT_MAX_DEPTH,
    all_frames: str = "scored",
) -> dict[str, float]:
    """Aggregate per-frame metrics over frames.

    Parameters
    ----------
    per_frame : mapping of arrays, or list of per-frame dicts
        As returned by :func:`frame_metrics` (batched) or rows of such values.
    how : {"mean", "pooled"}
        ``"mean"``: the mean of the per-frame values (the study's convention; PSNR is
        the mean of per-frame PSNR). ``"pooled"``: every scored pixel weighs the same;
        PSNR then comes from the pooled RMSE.
    max_depth : float
        Range for the pooled PSNR; a finite positive number.
    all_frames : {"scored", "every"}
        Frames of the all-pixel means: ``"scored"`` (default), the frames whose hole
        holds ground truth, the very frames of the hole means; ``"every"``, every frame
        with ground truth, as the KITTI devkit averages.

    Returns
    -------
    dict of str to float
        ``{region}_{metric}`` plus ``n_frames`` and ``n_skipped_hole`` (frames without
        valid ground truth in the hole, left out of the hole means and, unless
        ``all_frames="every"``, of the all-pixel means).

    Raises
    ------
    KeyError
        If a required column (``{region}_rmse``, ``_mae``, ``_count``) is missing.
    ValueError
        On no frames, columns of different lengths, an unknown ``how`` or an invalid
        ``max_depth``.
    """
    if how not in ("mean", "pooled"):
        raise InvalidInputError(f"how must be 'mean' or 'pooled', got {how!r}")
    if all_frames not in ("scored", "every"):
        raise InvalidInputError(f"all_frames must be 'scored' or 'every', got {all_frames!r}")
    max_depth = check_max_depth(max_depth)
    if isinstance(per_frame, list):
        if not per_frame:
            raise InvalidInputError("no frames to aggregate")
        cols = {k: np.asarray([row[k] for row in per_frame], dtype=np.float64) for k in per_frame[0]}
    else:
        cols = {k: np.atleast_1d(np.asarray(v, dtype=np.float64)) for k, v in per_frame.items()}
    missing = [f"{r}_{m}" for r in REGIONS for m in ("rmse", "mae", "count") if f"{r}_{m}" not in cols]
    if missing:
        raise UnknownNameError(f"per-frame metrics lack {missing}")
    # Columns are matched frame by frame; unequal lengths would fail deep in numpy indexing.
    lengths = {k: v.shape for k, v in cols.items()}
    if len({s for s in lengths.values()}) != 1 or any(len(s) != 1 for s in lengths.values()):
        raise InvalidInputError(f"per-frame metric columns must be 1-D and of one length, got shapes {lengths}")
    n_frames = len(cols["all_rmse"])
    if n_frames == 0:
        raise InvalidInputError("no frames to aggregate")
    out: dict[str, float] = {"n_frames": n_frames}
    # A frame whose hole holds no ground truth tested nothing: it leaves every mean, not
    # only the hole ones (its all-pixel error would be ~0 and its PSNR huge).
    scored = cols["hole_count"] > 0
    out["n_skipped_hole"] = int((~scored).sum())
    for region in REGIONS:
        count = cols[f"{region}_count"]
        ok = (count > 0) if region == "all" and all_frames == "every" else scored & (count > 0)
        for metric in METRIC_NAMES:
            key = f"{region}_{metric}"
            if key not in cols:
                continue
            vals = cols[key][ok]
            if not ok.any():
                out[key] = float("nan")
            elif how == "mean":
                out[key] = float(vals.mean())
            elif metric in ("rmse", "irmse"):
                out[key] = float(np.sqrt((vals**2 * count[ok]).sum() / count[ok].sum()))
            elif metric in ("mae", "imae"):
                out[key] = float((vals * count[ok]).sum() / count[ok].sum())
        if how == "pooled" and ok.any():
            out[f"{region}_psnr"] = float(
                20.0 * np.log10(max_depth / max(out[f"{region}_rmse"], MIN_PSNR_RMSE))
            )
    return out


def depth_binned_errors(
    pred: np.ndarray,
    gt: np.ndarray,
    hole: np.ndarray,
    *,
    edges: tuple[float, ...] = DEPTH_BIN_EDGES,
) -> list[dict[str, float]]:
    """Where a method's hole error comes from: pooled errors per true-depth bin.

    RMSE in metres weighs far pixels heavily; this breaks the squared error inside the
    holes down by the ground-truth depth, pooled over every scored pixel of the batch.

    Parameters
    ----------
    pred, gt, hole : numpy.ndarray
        As for :func:`frame_metrics`, ``(H, W)`` or ``(N, H, W)``.
    edges : tuple of float
        Increasing bin edges in metres; bin ``k`` is ``edges[k] <= gt < edges[k+1]``.

    Returns
    -------
    list of dict
        One row per bin: ``lo``, ``hi``, ``pixels`` (count), ``pixel_share`` and
        ``sse_share`` (of all scored hole pixels / of their summed squared error),
        ``rmse`` and ``bias`` (mean of prediction − truth, m; NaN for an empty bin).

    Raises
    ------
    ValueError
        No hole pixel with ground truth, or edges that are not increasing.

    Examples
    --------
    >>> gt = np.array([[5.0, 60.0]]); hole = np.ones_like(gt, dtype=bool)
    >>> rows = depth_binned_errors(np.array([[5.0, 40.0]]), gt, hole, edges=(0, 50, np.inf))
    >>> [(r["pixels"], r["sse_share"], r["bias"]) for r in rows]
    [(1, 0.0, 0.0), (1, 1.0, -20.0)]
    """
    pred_arr, gt, hole = _check_inputs(pred, gt, hole)
    edges_arr = np.asarray(edges, dtype=np.float64)
    if edges_arr.ndim != 1 or len(edges_arr) < 2 or not (np.diff(edges_arr) > 0).all():
        raise InvalidInputError(f"edges must be at least two increasing values, got {edges!r}")
    scored = hole & (gt > 0)
    if not scored.any():
        raise InvalidInputError("no hole pixel has ground truth: nothing to break down")
    p = _checked_scored(pred_arr[scored])
    g = gt[scored].astype(np.float64)
    err = p - g
    sq = err * err
    total_sse = sq.sum()
    rows = []
    for lo, hi in itertools.pairwise(edges_arr):
        in_bin = (g >= lo) & (g < hi)
        n = int(in_bin.sum())
        rows.append({
            "lo": float(lo), "hi": float(hi), "pixels": n,
            "pixel_share": n / len(g),
            # A perfect prediction has no squared error to share out.
            "sse_share": float(sq[in_bin].sum() / total_sse) if total_sse > 0 else 0.0,
            "rmse": float(np.sqrt(sq[in_bin].mean())) if n else float("nan"),
            "bias": float(err[in_bin].mean()) if n else float("nan"),
        })
    return rows
