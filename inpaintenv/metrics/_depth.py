"""Depth-inpainting metrics on valid ground truth: in the holes, where the input had no data, and over all pixels.

Only pixels with ground truth (``gt > 0``) count: ``S = gt > 0``; hole metrics use
``S ∩ H``, global ("all") metrics use ``S``, and "unmeasured" metrics ``S ∩ (H ∪ {input
== 0})``, the pixels a method was asked to fill (for a map input, whose input is the
ground truth itself, the hole's; for a single scan, every pixel the scan did not measure).
Per frame we report RMSE and MAE in metres, iRMSE and iMAE in 1/km (KITTI devkit), and
PSNR = ``20·log10(max_depth / RMSE)`` in dB; the ``kitti_*`` columns are KITTI depth
completion's own four on all pixels in its units (RMSE and MAE in mm, iRMSE and iMAE in 1/km).
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

import math
from collections.abc import Iterable, Mapping

import numpy as np

from ..conventions import DEFAULT_MAX_DEPTH, check_depth, check_mask, check_max_depth
from ..exceptions import InvalidInputError, UnfilledPixelsError, UnknownNameError
from ._checks import _check_inputs, _check_pred, _checked_scored
from ._devkit import interpolate_background
from ._records import metric_record, metric_records

__all__ = [
    "EXTRA_COLUMNS", "KITTI_METRICS", "METRIC_NAMES", "REGIONS", "UNFILLED", "UNMEASURED_METRICS",
    "ScoredPixels", "aggregate", "check_unfilled", "frame_metrics", "psnr_of", "task_of",
]

REGIONS = ("hole", "all")
METRIC_NAMES = ("rmse", "mae", "irmse", "imae", "psnr")
#: Metrics on the ground-truth pixels the input did not measure, and KITTI's own four (mm, 1/km).
UNMEASURED_METRICS = ("rmse", "mae", "psnr")
KITTI_METRICS = ("rmse", "mae", "irmse", "imae")
#: The per-frame columns beyond ``{REGIONS}_{METRIC_NAMES}`` and ``{REGIONS}_count``.
EXTRA_COLUMNS = (*(f"unmeasured_{m}" for m in UNMEASURED_METRICS), "unmeasured_count",
                 *(f"kitti_{m}" for m in KITTI_METRICS))
#: Predictions are clipped to this depth before inversion (iRMSE/iMAE), so an unfilled
#: pixel (0 m) gives a large but finite error instead of inf.
MIN_INVERSE_DEPTH = 0.1
#: RMSE floor for PSNR, so a perfect frame gives a large finite value, not inf.
MIN_PSNR_RMSE = 1e-6
#: How a prediction left at 0 m (unfilled) where ground truth exists is scored:
#: ``"error"`` refuses it in the hole (the default), ``"interpolate"`` fills such pixels first by the
#: KITTI devkit's background interpolation (:func:`interpolate_background`), ``"zero"``
#: scores them as 0 m (how the study scored its hole-only baselines).
UNFILLED = ("error", "interpolate", "zero")


def psnr_of(rmse: np.ndarray | float, max_depth: float) -> np.ndarray:
    """PSNR in dB of an RMSE for the range ``max_depth``: ``20·log10(max_depth / max(rmse, MIN_PSNR_RMSE))``."""
    return 20.0 * np.log10(max_depth / np.maximum(rmse, MIN_PSNR_RMSE))


def check_unfilled(value: object, name: str = "unfilled") -> str:
    """``value`` if it is one of :data:`UNFILLED`, else a ValueError listing them."""
    if not isinstance(value, str) or value not in UNFILLED:
        raise InvalidInputError(f"{name} must be one of {', '.join(map(repr, UNFILLED))}, got {value!r}")
    return value


def frame_metrics(
    pred: np.ndarray,
    gt: np.ndarray,
    hole: np.ndarray,
    *,
    max_depth: float = DEFAULT_MAX_DEPTH,
    unfilled: str = "error",
    inputs: np.ndarray | None = None,
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
        0 m (see :data:`UNFILLED`). With ``inputs``, "in the hole" reads "unmeasured".
    inputs : numpy.ndarray, optional
        The measured input the method was given before the hole was cut (e.g. a single
        LiDAR scan), of ``gt``'s shape, 0 = not measured; by default ``gt`` itself (a map input).

    Returns
    -------
    dict of str to numpy.ndarray
        Keys ``{region}_{metric}`` for region in ``("hole", "all")`` and metric in
        ``("rmse", "mae", "irmse", "imae", "psnr")``, plus ``hole_count`` and
        ``all_count`` (number of scored pixels); ``unmeasured_rmse``, ``_mae``, ``_psnr``
        and ``_count`` on ``(gt > 0) & ((inputs == 0) | hole)`` (the hole's pixels for a
        map input); and ``kitti_rmse``, ``kitti_mae`` (mm), ``kitti_irmse``,
        ``kitti_imae`` (1/km), the devkit's four on all pixels. Each value has shape ``(N,)``
        (or is a 0-d array for a single frame). Hole (unmeasured) metrics are NaN where
        ``hole_count == 0`` (``unmeasured_count == 0``).
    """
    pred_arr, gt, hole = _check_inputs(pred, gt, hole)
    # NaN/inf would pass a plain "<= 0" test and give NaN/inf PSNR in every row.
    max_depth = check_max_depth(max_depth)
    if inputs is not None:
        inputs = check_depth(inputs, name="inputs")
        if inputs.shape != gt.shape:
            raise InvalidInputError(f"inputs has shape {inputs.shape}, ground truth {gt.shape}")
    scored = ScoredPixels(gt, hole, inputs=inputs, check_input=False)
    return scored.metrics(pred_arr, max_depth=max_depth, unfilled=unfilled)


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
    inputs : numpy.ndarray, optional
        The measured input before the hole was cut, 0 = not measured (default: ``gt``,
        a map input); it decides the unmeasured pixels.
    check_input : bool, default True
        False skips checking ``gt``, ``hole`` and ``inputs``, for callers that have just checked
        them (float32 ground truth from :func:`~inpaintenv.conventions.check_depth`, a
        boolean mask of its shape); unchecked input then gives wrong numbers silently.

    Attributes
    ----------
    shape : tuple of int
        Shape of ``gt``.
    all_count, hole_count, unmeasured_count : numpy.ndarray
        Scored pixels per frame (``(N,)`` int64, or 0-d for one frame): valid ground
        truth, valid ground truth inside the hole, and valid ground truth the input did not measure.
    """

    def __init__(
        self, gt: np.ndarray, hole: np.ndarray, *, inputs: np.ndarray | None = None, check_input: bool = True
    ):
        if check_input:
            gt = check_depth(gt, name="ground truth")
            hole = check_mask(hole, gt.shape)
            if inputs is not None and check_depth(inputs, name="inputs").shape != gt.shape:
                raise InvalidInputError(f"inputs has shape {np.shape(inputs)}, ground truth {gt.shape}")
        self.shape: tuple[int, ...] = gt.shape
        self._single = gt.ndim == 2
        flat_gt, flat_hole = gt.reshape(-1), hole.reshape(-1)
        # Flat indices from one scan, then cheap takes: boolean-mask gathers rescan the
        # whole frame each time and were most of the cost of scoring a KITTI frame.
        # Flat order walks frames in order: frame k's pixels are one contiguous run.
        self._index = np.flatnonzero(flat_gt > 0)
        self._gt = flat_gt.take(self._index).astype(np.float64)
        self._in_hole = flat_hole.take(self._index)
        # For a map input every valid pixel outside the hole was given to the method.
        self._unmeasured = self._in_hole if inputs is None else self._in_hole | (
            np.asarray(inputs).reshape(-1).take(self._index) == 0)
        # Pixels per frame from where each frame starts in the sorted index (counting
        # along an axis of the full-size mask costs as much as the gather itself).
        n_frames = 1 if self._single else len(gt)
        starts = np.arange(n_frames + 1) * (flat_gt.size // n_frames)
        n_all = np.diff(np.searchsorted(self._index, starts))
        n_hole = np.diff(np.searchsorted(self._index[self._in_hole], starts))
        n_unmeasured = np.diff(np.searchsorted(self._index[self._unmeasured], starts))
        self.all_count = n_all[0] if self._single else n_all
        self.hole_count = n_hole[0] if self._single else n_hole
        self.unmeasured_count = n_unmeasured[0] if self._single else n_unmeasured
        # Per region: pixels per frame, their layout for _frame_sums, and the divisor
        # of the means (NaN for a frame without any: its metrics are NaN).
        self._regions = {
            region: (n, _runs(n), np.where(n > 0, n, np.nan))
            for region, n in (("hole", n_hole), ("all", n_all), ("unmeasured", n_unmeasured))
        }

    def metrics(
        self, pred: np.ndarray, *, max_depth: float = DEFAULT_MAX_DEPTH, unfilled: str = "error",
        check_input: bool = True,
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
        check_input : bool, default True
            False skips checking ``pred``, ``max_depth`` and ``unfilled``, for callers that checked
            them where they entered (``evaluate``: a finite, non-negative float32 ``pred`` of the
            ground truth's shape); unchecked input then gives wrong numbers silently.

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
        if not check_input:
            return self._metrics(pred, pred.reshape(-1).take(self._index).astype(np.float64), max_depth, unfilled)
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
            elif n := int(np.count_nonzero((p == 0) & self._unmeasured)):
                # Where the method was given the measurement, 0 is scored as given.
                raise UnfilledPixelsError(
                    f"prediction is 0 m (unfilled) at {n} {'hole' if self._unmeasured is self._in_hole else 'unmeasured'} "
                    "pixels with ground truth; fill them, or set unfilled "
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
            out[f"{region}_psnr"] = psnr_of(rmse, max_depth)
            out[f"{region}_count"] = np.asarray(n, dtype=np.int64)
        out.update(self._unmeasured_metrics(err, max_depth))
        # KITTI's four are the all-pixel ones in the devkit's units: mm, and 1/km as here.
        out["kitti_rmse"], out["kitti_mae"] = 1000.0 * out["all_rmse"], 1000.0 * out["all_mae"]
        out["kitti_irmse"], out["kitti_imae"] = out["all_irmse"].copy(), out["all_imae"].copy()
        if self._single:
            out = {k: v[0] for k, v in out.items()}
        return out


    def _unmeasured_metrics(self, err: np.ndarray, max_depth: float) -> dict[str, np.ndarray]:
        """RMSE, MAE, PSNR and count on the pixels the input did not measure (``err``: all scored pixels)."""
        n, runs, denom = self._regions["unmeasured"]
        e = err[self._unmeasured]
        rmse = np.sqrt(_frame_sums(e * e, runs) / denom)
        return {"unmeasured_rmse": rmse, "unmeasured_mae": _frame_sums(np.abs(e), runs) / denom,
                "unmeasured_psnr": psnr_of(rmse, max_depth),
                "unmeasured_count": np.asarray(n, dtype=np.int64)}


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


def task_of(hole_fractions: Iterable[float]) -> str:
    """:func:`aggregate`'s ``task`` for frames of these hole fractions.

    ``"unmeasured"`` when no frame had a hole cut (``densify-v1``), else ``"hole"``.
    """
    fractions = list(hole_fractions)
    return "unmeasured" if fractions and all(f == 0 for f in fractions) else "hole"


def aggregate(
    per_frame: Mapping[str, np.ndarray] | list[Mapping[str, float]],
    *,
    how: str = "mean",
    max_depth: float = DEFAULT_MAX_DEPTH,
    all_frames: str = "scored",
    task: str = "hole",
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
    task : {"hole", "unmeasured"}
        Which pixels a frame's task is to fill: those of its hole (default), or, where no
        hole is cut (``densify-v1``), every pixel the input did not measure. A frame
        whose task pixels hold no ground truth tested nothing.

    Returns
    -------
    dict of str to float
        ``{region}_{metric}`` (with the ``unmeasured_*`` and ``kitti_*`` columns when
        given) plus ``n_frames`` and ``n_skipped_hole`` (frames without valid ground
        truth among their task pixels, left out of the hole and unmeasured means and,
        unless ``all_frames="every"``, of the all-pixel means). The ``kitti_*`` means are
        over every frame with ground truth, as the KITTI devkit averages.

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
    if task not in ("hole", "unmeasured"):
        raise InvalidInputError(f"task must be 'hole' or 'unmeasured', got {task!r}")
    max_depth = check_max_depth(max_depth)
    if isinstance(per_frame, list):
        if not per_frame:
            raise InvalidInputError("no frames to aggregate")
        # Rows may be whole result rows: the metric records' columns and the counts are read.
        known = {r.name for r in metric_records()} | {f"{r}_count" for r in (*REGIONS, "unmeasured")}
        cols = {k: np.asarray([row[k] for row in per_frame], dtype=np.float64) for k in per_frame[0] if k in known}
    else:
        cols = {k: np.atleast_1d(np.asarray(v, dtype=np.float64)) for k, v in per_frame.items()}
    missing = [f"{r}_{m}" for r in REGIONS for m in ("rmse", "mae", "count") if f"{r}_{m}" not in cols]
    missing += ["unmeasured_count"] if task == "unmeasured" and "unmeasured_count" not in cols else []
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
    scored = cols[f"{task}_count"] > 0
    out["n_skipped_hole"] = int((~scored).sum())
    # (region, its metrics, the column counting its pixels)
    regions = [(r, METRIC_NAMES, r) for r in REGIONS]
    regions += [("unmeasured", UNMEASURED_METRICS, "unmeasured")] if "unmeasured_count" in cols else []
    regions += [("kitti", KITTI_METRICS, "all")]
    for region, names, counted in regions:
        count = cols[f"{counted}_count"]
        every = region == "kitti" or (region == "all" and all_frames == "every")
        ok = (count > 0) if every else scored & (count > 0)
        for metric in names:
            key = f"{region}_{metric}"
            if key not in cols:
                continue
            out[key] = _pool(metric_record(key).pool, cols[key], count, ok, how)
        if how == "pooled" and ok.any() and "psnr" in names:
            out[f"{region}_psnr"] = float(
                psnr_of(out[f"{region}_rmse"], max_depth)
            )
    # Every other metric record the rows hold, by its own record (evaluate's computed metrics, intervals).
    for record in metric_records():
        if record.name in out or record.name not in cols:
            continue
        count = cols.get(f"{task}_count" if record.count == "task" else record.count)
        if count is None:
            raise UnknownNameError(f"per-frame metrics lack {record.count!r}, the pixels of {record.name!r}")
        ok = (count > 0) & np.isfinite(cols[record.name])
        ok &= True if record.frames == "every" or (record.frames == "all" and all_frames == "every") else scored
        if record.pool == "psnr":  # from the pooled RMSE of its region
            rmse = out.get(record.name[: -len("psnr")] + "rmse", float("nan"))
            out[record.name] = float(20.0 * np.log10(max_depth / max(rmse, MIN_PSNR_RMSE))) \
                if how == "pooled" and not math.isnan(rmse) else _pool("frames", cols[record.name], count, ok, how)
        else:
            out[record.name] = _pool(record.pool, cols[record.name], count, ok, how)
    return out


def _pool(pool: str, values: np.ndarray, count: np.ndarray, ok: np.ndarray, how: str) -> float:
    """One metric over the frames ``ok``: their mean (``how="mean"``), or pooled over pixels by ``pool``."""
    if not ok.any():
        return float("nan")
    vals, weights = values[ok], count[ok]
    if how == "mean" or pool == "frames":
        return float(vals.mean())
    if pool == "rms":
        return float(np.sqrt((vals**2 * weights).sum() / weights.sum()))
    if pool == "mean":
        return float((vals * weights).sum() / weights.sum())
    return float(vals.mean())  # "psnr": set from the pooled RMSE by the caller
