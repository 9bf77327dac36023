"""How well a per-pixel interval says where a fill can be trusted: coverage, width, rejection.

A method may give, beside its reconstruction ``pred``, an interval ``[low, high]`` per
pixel (metres) that should hold the true depth with probability ``coverage`` (e.g. 0.9).
It is scored on the hole pixels with ground truth (``gt > 0`` inside the hole), per frame:

``hole_coverage``
    The fraction of those pixels whose truth lies in ``[low, high]`` (bounds included).
``hole_interval_width``
    The mean of ``high - low`` over them, in metres.
``rmse_keep_90``, ``rmse_keep_80``, ``rmse_keep_50``
    The error–rejection curve: the hole RMSE of the prediction over the most confident
    90 / 80 / 50 % of those pixels only, the confidence of a pixel being its interval's
    width (narrower = more confident; widths are compared rounded to the millimetre, so
    the float rounding of equal widths ranks nothing). Keeping a fraction ``f`` of ``n`` pixels keeps
    ``k = f·n`` of them (a real number, see "ties" below); ``f = 1`` is the plain hole RMSE.
``rmse_cut_80``
    ``1 - rmse_keep_80 / hole_rmse``: the share of hole RMSE removed by keeping the most
    confident 80 % (the issue's goal is at least 1/3).
``rejection_auc``
    The area under the curve, normalised: the mean of ``RMSE_keep(f) / RMSE_keep(1)`` over
    the keep fractions :data:`KEEP_GRID` (0.05, 0.10, ..., 1.00). 1.0 means the
    confidence orders pixels no better than chance (a constant width gives exactly 1.0);
    lower is better; the ``oracle`` curve, which keeps the pixels of smallest error, is the
    lowest any ranking can reach. NaN when the frame's hole RMSE is 0.
``border_rmse_keep_90/80/50``, ``border_rejection_auc``
    The same curve for a baseline that needs no interval at all: keep the hole pixels
    nearest the hole's border (Euclidean distance to the nearest pixel outside the hole,
    ``cv2.distanceTransform`` with ``DIST_L2`` and a precise mask, ranked by its square
    rounded to an integer so that the last bit of OpenCV's float result never re-ranks
    tied pixels; the image's edge is not a border). An interval is worth its name when it cuts more than this does.
``oracle_rmse_keep_80``, ``oracle_rejection_auc``
    The curve of the ideal ranking (by the pixel's own absolute error).

Ties: pixels of equal confidence are kept or dropped together *in proportion*: when the
cut falls inside a group of ``m`` tied pixels of which ``j`` are needed, each contributes
``j/m`` of its squared error. This is the expected value over every random tie-break,
so it is deterministic, independent of pixel order, and a ranking that says nothing
(all widths equal) scores exactly the full-hole RMSE at every fraction.

Frames whose hole holds no ground truth get NaN in every column (as
:func:`inpaintenv.metrics.frame_metrics` gives them NaN hole metrics).

An interval may be given as a standard deviation: :func:`interval_from_std` turns
``std`` into ``[pred - z·std, pred + z·std]`` clipped at 0 m, ``z`` the two-sided normal
quantile of the coverage asked (``statistics.NormalDist().inv_cdf((1 + coverage) / 2)``,
1.645 for 0.9).
"""

from __future__ import annotations

from statistics import NormalDist

import numpy as np

from ..conventions import as_depth_array, check_depth, check_mask
from ..exceptions import InvalidInputError, InvalidTypeError

__all__ = [
    "INTERVAL_COLUMNS", "KEEP_FRACTIONS", "KEEP_GRID", "Coverage", "as_coverage", "border_distance",
    "check_coverage", "check_interval",
    "interval_from_std", "interval_metrics", "normal_quantile", "rejection_curve",
]

#: The keep fractions reported as columns (``rmse_keep_90`` ...).
KEEP_FRACTIONS: tuple[float, ...] = (0.9, 0.8, 0.5)
#: The keep fractions the area under the rejection curve is averaged over: 0.05, 0.10, ..., 1.00.
KEEP_GRID: tuple[float, ...] = tuple(round(0.05 * i, 2) for i in range(1, 21))
#: Per-frame columns :func:`inpaintenv.evaluate.evaluate` adds to a row when a method gives intervals.
INTERVAL_COLUMNS: tuple[str, ...] = (
    "hole_coverage", "hole_interval_width", "rmse_keep_90", "rmse_keep_80", "rmse_keep_50", "rmse_cut_80",
    "rejection_auc", "border_rmse_keep_90", "border_rmse_keep_80", "border_rmse_keep_50", "border_rejection_auc",
    "oracle_rmse_keep_80", "oracle_rejection_auc",
)


class Coverage(float):
    """A nominal interval coverage already checked: a float strictly between 0 and 1.

    Made by :func:`check_coverage` where a coverage enters (a command's option, a public
    function's argument); every function it is passed on to takes it as it is
    (:func:`as_coverage`), so one value is checked once however deep it travels.
    Building one checks it too: no ``Coverage`` outside (0, 1) exists.
    """

    __slots__ = ()

    def __new__(cls, value: object, name: str = "coverage") -> Coverage:
        if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
            raise InvalidTypeError(f"{name} must be a number in (0, 1), got {value!r}")
        v = float(value)
        if not 0.0 < v < 1.0:
            raise InvalidInputError(f"{name} must be in (0, 1) (e.g. 0.9 for a 90 % interval), got {value!r}")
        return super().__new__(cls, v)


def check_coverage(value: object, name: str = "coverage") -> Coverage:
    """``value`` as a :class:`Coverage`: a float strictly between 0 and 1 (the nominal coverage of an interval)."""
    return Coverage(value, name)


def as_coverage(value: object, name: str = "coverage") -> Coverage:
    """``value`` itself when it is a :class:`Coverage` (checked where it entered), else :func:`check_coverage` of it."""
    return value if isinstance(value, Coverage) else check_coverage(value, name)


def normal_quantile(coverage: float) -> float:
    """``z`` with ``P(|Z| <= z) = coverage`` for a standard normal ``Z`` (1.645 for 0.9)."""
    return NormalDist().inv_cdf((1.0 + as_coverage(coverage)) / 2.0)


def interval_from_std(pred: np.ndarray, std: np.ndarray, coverage: float = 0.9) -> tuple[np.ndarray, np.ndarray]:
    """The normal interval ``[pred - z·std, pred + z·std]`` of ``coverage``, clipped at 0 m.

    Parameters
    ----------
    pred, std : numpy.ndarray
        Prediction and standard deviation in metres, same shape; ``std`` finite and >= 0
        wherever ``pred`` is finite.
    coverage : float
        Nominal coverage in (0, 1).

    Returns
    -------
    low, high : numpy.ndarray
        float64 arrays of ``pred``'s shape.
    """
    coverage = as_coverage(coverage)
    p = as_depth_array(pred, "prediction").astype(np.float64)
    s = as_depth_array(std, "std").astype(np.float64)
    if s.shape != p.shape:
        raise InvalidInputError(f"std has shape {s.shape}, prediction {p.shape}")
    bad = np.isfinite(p) & ~(np.isfinite(s) & (s >= 0))
    if bad.any():
        raise InvalidInputError(f"std is NaN, infinite or negative at {int(bad.sum())} pixels; it must be finite and >= 0")
    z = normal_quantile(coverage)
    return np.maximum(p - z * s, 0.0), p + z * s


def check_interval(
    pred: np.ndarray, low: np.ndarray, high: np.ndarray, hole: np.ndarray, name: str = "interval"
) -> tuple[np.ndarray, np.ndarray]:
    """``(low, high)`` as float64 arrays, refused unless they make a valid interval in the hole.

    At every hole pixel (the pixels filled): ``low`` and ``high`` finite, ``0 <= low <=
    pred <= high``. Outside the hole they are not read. ``low`` and ``high`` must have
    ``pred``'s shape (``(H, W)`` or ``(N, H, W)``) and hold at least one pixel.

    Raises
    ------
    InvalidInputError
        Naming ``name`` and the rule broken (shape, empty, NaN/inf, negative, inverted,
        not holding the prediction) with the number of pixels.
    InvalidTypeError
        If a bound is not a floating-point array.
    """
    p = as_depth_array(pred, "prediction")
    lo = as_depth_array(low, f"{name} low")
    hi = as_depth_array(high, f"{name} high")
    for label, arr in (("low", lo), ("high", hi)):
        if arr.shape != p.shape:
            raise InvalidInputError(f"{name} {label} has shape {arr.shape}, the prediction {p.shape}")
    if p.size == 0:
        raise InvalidInputError(f"{name} is empty (shape {p.shape})")
    h = check_mask(hole, p.shape)
    pl, ll, hl = p[h].astype(np.float64), lo[h].astype(np.float64), hi[h].astype(np.float64)
    rules = (
        (~(np.isfinite(ll) & np.isfinite(hl)), "is NaN or infinite"),
        (ll < 0, "has a negative low bound"),
        (ll > hl, "is inverted (low > high)"),
        (~((ll <= pl) & (pl <= hl)), "does not hold the prediction (low <= prediction <= high)"),
    )
    for bad, what in rules:
        if n := int(np.count_nonzero(bad)):
            raise InvalidInputError(f"{name} {what} at {n} hole pixels; it must be finite with 0 <= low <= "
                                    "prediction <= high wherever the hole is filled")
    return lo.astype(np.float64), hi.astype(np.float64)


def border_distance(hole: np.ndarray) -> np.ndarray:
    """Euclidean distance (pixels) of each hole pixel to the nearest pixel outside the hole; 0 outside.

    ``hole`` is ``(H, W)`` or ``(N, H, W)`` boolean; computed per frame with
    ``cv2.distanceTransform(DIST_L2, DIST_MASK_PRECISE)``. A frame that is all hole has no
    border: every pixel gets the same (large) distance, so its ranking is a tie.
    """
    import cv2  # lazy: only the border baseline needs OpenCV

    h = np.asarray(hole, dtype=bool)
    frames = h[None] if h.ndim == 2 else h
    out = np.empty(frames.shape, dtype=np.float32)
    for k, frame in enumerate(frames):
        out[k] = cv2.distanceTransform(frame.astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    return out[0] if h.ndim == 2 else out


def rejection_curve(
    sq_err: np.ndarray, score: np.ndarray, frame: np.ndarray, n_frames: int, fractions: tuple[float, ...]
) -> np.ndarray:
    """RMSE per frame when only the fraction ``f`` of pixels with the smallest ``score`` is kept.

    Parameters
    ----------
    sq_err, score, frame : numpy.ndarray
        Per scored pixel: squared error, confidence score (smaller = more confident) and
        the frame it belongs to (``0..n_frames-1``), 1-D of one length.
    n_frames : int
        Number of frames.
    fractions : tuple of float
        Keep fractions in (0, 1].

    Returns
    -------
    numpy.ndarray
        ``(n_frames, len(fractions))`` RMSE; NaN for a frame without pixels. Ties are
        split in proportion (see the module docstring).
    """
    out = np.full((n_frames, len(fractions)), np.nan)
    keep = np.asarray(fractions, dtype=np.float64)
    # Frame by frame: a frame's numbers never depend on the other frames of its batch.
    for fr in np.unique(frame):
        sel = frame == fr
        out[fr] = _curve(sq_err[sel].astype(np.float64), score[sel], keep)
    return out


def _curve(sq_err: np.ndarray, score: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """RMSE of one frame's pixels at each keep fraction, ties split in proportion."""
    order = np.argsort(score, kind="stable")
    s, e = score[order], sq_err[order]
    n = e.size
    new = np.ones(n, dtype=bool)
    new[1:] = s[1:] != s[:-1]
    g_start = np.flatnonzero(new)  # tie groups: runs of equal score
    g_size = np.diff(np.append(g_start, n))
    cum = np.concatenate(([0.0], np.cumsum(e)))
    g_mean = (cum[g_start + g_size] - cum[g_start]) / g_size
    k = keep * n  # pixels kept, a real number
    last = np.maximum(np.ceil(k).astype(np.int64), 1) - 1  # position of the last pixel kept
    g = np.searchsorted(g_start, last, side="right") - 1  # its tie group
    sse = cum[g_start[g]] + (k - g_start[g]) * g_mean[g]
    return np.sqrt(np.maximum(sse, 0.0) / k)


def interval_metrics(
    pred: np.ndarray, gt: np.ndarray, hole: np.ndarray, low: np.ndarray, high: np.ndarray
) -> dict[str, np.ndarray]:
    """Coverage, width and error–rejection curves of an interval, per frame, vectorised.

    Parameters
    ----------
    pred : numpy.ndarray
        Reconstruction in metres, ``(H, W)`` or ``(N, H, W)``.
    gt : numpy.ndarray
        Ground truth of the same shape, 0 = no measurement.
    hole : numpy.ndarray
        Boolean occlusion mask of the same shape.
    low, high : numpy.ndarray
        Interval bounds in metres (checked by :func:`check_interval`).

    Returns
    -------
    dict of str to numpy.ndarray
        The columns of :data:`INTERVAL_COLUMNS` (defined in the module docstring), each
        ``(N,)`` float64 (0-d for one frame); NaN for a frame without ground truth in its hole.
    """
    gt = check_depth(gt, name="ground truth")
    hole = check_mask(hole, gt.shape)
    lo, hi = check_interval(pred, low, high, hole)
    single = gt.ndim == 2
    if single:
        pred, gt, hole, lo, hi = (np.asarray(a)[None] for a in (pred, gt, hole, lo, hi))
    n_frames, frame_size = len(gt), gt[0].size
    idx = np.flatnonzero(((gt > 0) & hole).reshape(-1))
    frame = idx // frame_size
    g = gt.reshape(-1)[idx].astype(np.float64)
    p = np.asarray(pred, dtype=np.float64).reshape(-1)[idx]
    lo_v, hi_v = lo.reshape(-1)[idx], hi.reshape(-1)[idx]
    count = np.bincount(frame, minlength=n_frames).astype(np.float64)
    denom = np.where(count > 0, count, np.nan)
    out: dict[str, np.ndarray] = {
        "hole_coverage": np.bincount(frame, (lo_v <= g) & (g <= hi_v), minlength=n_frames) / denom,
        "hole_interval_width": np.bincount(frame, hi_v - lo_v, minlength=n_frames) / denom,
    }
    sq = (p - g) ** 2
    fractions = tuple(sorted(set(KEEP_FRACTIONS) | set(KEEP_GRID)))
    scores = {
        # Widths compared to the millimetre: float rounding of equal widths must not rank pixels.
        "": np.round(hi_v - lo_v, 3),
        # Ranked by the squared distance, an integer (dx² + dy²): OpenCV's float result can
        # differ in the last bit between processes, which must not re-rank tied pixels.
        "border_": np.rint(border_distance(hole).reshape(-1)[idx].astype(np.float64) ** 2),
        "oracle_": sq,
    }
    for prefix, score in scores.items():
        curve = rejection_curve(sq, score, frame, n_frames, fractions)
        col = {f: curve[:, j] for j, f in enumerate(fractions)}
        full = col[1.0]
        for f in KEEP_FRACTIONS if prefix != "oracle_" else (0.8,):
            out[f"{prefix}rmse_keep_{round(f * 100)}"] = col[f]
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.stack([col[f] for f in KEEP_GRID], axis=1) / full[:, None]
            out[f"{prefix}rejection_auc"] = np.where(full > 0, ratio.mean(axis=1), np.nan)
            if prefix == "":
                out["rmse_cut_80"] = np.where(full > 0, 1.0 - col[0.8] / full, np.nan)
    out = {c: out[c] for c in INTERVAL_COLUMNS}
    return {k: v[0] for k, v in out.items()} if single else out
