"""Classical candidate fills used as input priors by learned inpainters (no torch).

A learned model that starts from strong classical fills only has to learn where each
one is right (a per-pixel blend) and a small correction, which a CPU-sized network
can do in minutes; learning depth from scratch cannot (the study's U-Net at a CPU
budget stays far behind the classical fills, docs/reproduction.md). The candidates reuse
the classical estimators' fill functions and are computed on the *whole* frame, so a
row-wise fill stays exact when a network later sees a crop of rows.

>>> import numpy as np
>>> from estimators.candidates import prior_features, CANDIDATES
>>> x = np.full((4, 6), 10.0, dtype=np.float32); x[1:3, 2:4] = np.nan
>>> prior_features(x).shape == (3 + len(CANDIDATES), 4, 6)
True
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any
from concurrent.futures import ThreadPoolExecutor

import cv2
import numpy as np

from inpaintenv.conventions import check_depth

from ._residual_features import AtPixels, flat_pixels, overlap
from ._scan import AxisScan
from .classical import in_inverse_depth
from .classical.harmonic import harmonic_fill
from .classical.ipbasic import IPBasicInpainter
from .classical.nearest import nearest_fill
from .classical.scanline import scanline_fill
from inpaintenv.exceptions import InvalidInputError

__all__ = ["AVAILABLE_CANDIDATES", "BASE_CHANNELS", "CANDIDATES", "ENDPOINT_CHANNELS", "endpoint_values", "GAP_CHANNELS", "candidate_fills", "check_candidates", "gap_distances", "prior_features", "residual_channels", "residual_features", "row_band_quantile", "row_band_quantiles", "window_extreme"]

#: Candidate fills, in channel order: row-wise linear interpolation of depth, of inverse
#: depth, column-wise linear interpolation of depth, harmonic (Laplace) interpolation.
CANDIDATES: tuple[str, ...] = ("scanline", "scanline-inverse", "vertical", "harmonic")
#: Channels before the candidates in :func:`prior_features`.
BASE_CHANNELS: tuple[str, ...] = ("depth", "hole", "valid")
#: Channels of :func:`gap_distances`, appended after the candidates when asked for.
GAP_CHANNELS: tuple[str, ...] = ("gap-left", "gap-right", "gap-up", "gap-down")
#: Channels of :func:`endpoint_values`, appended after the gap lengths when asked for.
ENDPOINT_CHANNELS: tuple[str, ...] = ("end-left", "end-right", "end-up", "end-down")
#: Distance reported where no measurement lies in that direction (longer than any row).
NO_MEASUREMENT_DISTANCE = 2048


def _vertical(values: np.ndarray, known: np.ndarray) -> np.ndarray:
    return scanline_fill(values.T, known.T).T


def _check_values_known(values: np.ndarray, known: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(values as float32, known)`` after checking both are 2-D, of one shape, ``known`` bool."""
    known = np.asarray(known)
    if known.ndim != 2 or known.dtype != bool or np.shape(values) != known.shape:
        raise InvalidInputError(
            f"values and known must be 2-D arrays of one shape, known bool; got {np.shape(values)} "
            f"and {known.dtype} {known.shape}"
        )
    return np.asarray(values, dtype=np.float32), known


#: Rows above and below a pixel's row pooled by the row-context fills (a band of 9 rows).
ROW_BAND = 4


#: The row-context candidates and their quantile of the measured depth in each row band.
ROW_QUANTILES: dict[str, float] = {"row-median": 0.5, "row-far": 0.9}


def row_band_quantile(values: np.ndarray, known: np.ndarray, q: float, band: int = ROW_BAND) -> np.ndarray:
    """The ``q``-quantile of the measured depth in each band of ``2·band + 1`` rows.

    Context, not interpolation: a large hole can hide far scene (the road's end, a gap
    between buildings) that no fill from its border reaches; how far the rest of the
    same rows reaches tells a learned blend how much to push a pixel back. Measured
    pixels keep their value; rows with no measurement in their band take the nearest
    such row's value; a frame without any measurement gives zeros.

    Parameters
    ----------
    values : numpy.ndarray
        ``(H, W)`` metres, read where ``known``.
    known : numpy.ndarray
        ``(H, W)`` bool.
    q : float
        Quantile in [0, 1] (linear interpolation between order statistics).
    band : int
        Rows pooled on each side.

    Returns
    -------
    numpy.ndarray
        ``(H, W)`` float32 metres.
    """
    if not 0.0 <= q <= 1.0:
        raise InvalidInputError(f"q must be in [0, 1], got {q!r}")
    if int(band) != band or band < 0:
        raise InvalidInputError(f"band must be a non-negative integer, got {band!r}")
    values, known = _check_values_known(values, known)
    return row_band_quantiles(values, known, [q], int(band))[0]


def row_band_quantiles(values: np.ndarray, known: np.ndarray, qs: Sequence[float],
                       band: int = ROW_BAND) -> list[np.ndarray]:
    """:func:`row_band_quantile` for several quantiles (checked arguments), from one sort.

    A scan measures a few percent of a band's pixels: each row's measurements are sorted
    first and only they (at most the row's largest count) enter the band's sort, 10-20x
    fewer values than the band's pixels (26 -> ~3 ms a quantile on a 352x1216 scan).
    Unknown pixels sort last as +inf, so each band's k-th order statistic is an index.
    """
    height, width = values.shape
    if not known.any():
        return [np.zeros((height, width), np.float32) for _ in qs]
    keyed = np.sort(np.where(known, values, np.inf).astype(np.float32), axis=1)
    keyed = keyed[:, : max(int(known.sum(axis=1).max()), 1)]
    padded = np.pad(keyed, ((band, band), (0, 0)), constant_values=np.inf)
    bands = np.lib.stride_tricks.sliding_window_view(padded, (2 * band + 1, keyed.shape[1]))[:, 0]
    ordered = np.sort(bands.reshape(height, -1), axis=1)
    count = np.count_nonzero(np.isfinite(ordered), axis=1)
    has, rows = count > 0, np.arange(height)
    out = []
    for q in qs:
        pos = q * np.maximum(count - 1, 0)
        lo = np.floor(pos).astype(np.int64)
        hi = np.minimum(lo + 1, np.maximum(count - 1, 0))
        frac = (pos - lo).astype(np.float32)
        per_row = np.where(has, ordered[rows, lo] * (1 - frac) + np.where(frac > 0, ordered[rows, hi], 0) * frac, 0)
        per_row = np.interp(rows, rows[has], per_row[has]).astype(np.float32)
        out.append(np.where(known, values, per_row[:, None]).astype(np.float32))
    return out


#: Side of the windows of the ``window-near`` / ``window-far`` candidates (pixels).
WINDOW = 15


def window_extreme(values: np.ndarray, known: np.ndarray, far: bool, size: int = WINDOW) -> np.ndarray:
    """The nearest (``far=False``) or farthest measured depth in a ``size``-pixel square window.

    Context for a sparse input such as a single LiDAR scan: the spread between the two tells
    a learned blend whether a pixel lies on one surface or at a depth edge. Pixels with no
    measurement in their window take the nearest measurement's depth.
    """
    values, known = _check_values_known(values, known)
    every = AtPixels(values, known, np.arange(values.size))  # the whole frame: one definition with residual_features
    return every.window(bool(far), int(size)).reshape(values.shape)


def _ipbasic(values: np.ndarray, known: np.ndarray) -> np.ndarray:
    # Its morphology prefers the nearer surface: strong on a sparse scan, where the
    # smooth fills average across depth edges.
    filled = IPBasicInpainter()._fill_frame(np.where(known, values, 0.0).astype(np.float32))
    return np.where(known, values, filled).astype(np.float32)  # its median blur moves measured pixels


def _ipbasic_scan(values: np.ndarray, known: np.ndarray) -> np.ndarray:
    # The registry's ipbasic-scan: no large-hole extrapolation, the strongest classical fill
    # of a single scan's holes.
    filled = IPBasicInpainter(large_hole_kernel=None)._fill_frame(np.where(known, values, 0.0).astype(np.float32))
    return np.where(known, values, filled).astype(np.float32)


_FILLS = {
    "scanline": lambda v, k: scanline_fill(v, k),
    "scanline-inverse": lambda v, k: in_inverse_depth(scanline_fill, v, k),
    "vertical": _vertical,
    "harmonic": harmonic_fill,
    "vertical-inverse": lambda v, k: in_inverse_depth(_vertical, v, k),
    "harmonic-inverse": lambda v, k: in_inverse_depth(harmonic_fill, v, k),
    # Row context: how near / how far the rest of the pixel's rows reach.
    "row-median": lambda v, k: row_band_quantile(v, k, ROW_QUANTILES["row-median"]),
    "row-far": lambda v, k: row_band_quantile(v, k, ROW_QUANTILES["row-far"]),
    # Fills that suit a sparse scan: morphological, nearest, and the window's extremes.
    "ipbasic": _ipbasic,
    "ipbasic-scan": _ipbasic_scan,
    "nearest": nearest_fill,
    "window-near": lambda v, k: window_extreme(v, k, far=False),
    "window-far": lambda v, k: window_extreme(v, k, far=True),
}
#: Every fill :func:`candidate_fills` knows (CANDIDATES is the default subset).
AVAILABLE_CANDIDATES: tuple[str, ...] = tuple(_FILLS)


def check_candidates(names: Sequence[str], name: str = "candidates") -> tuple[str, ...]:
    """``names`` as a tuple, after checking it is a non-empty sequence of known fills.

    Parameters
    ----------
    names : sequence of str (a tuple or a list; a plain string is refused)
        Candidate fills, from :data:`AVAILABLE_CANDIDATES`.
    name : str, default "candidates"
        The parameter the error names.

    Returns
    -------
    tuple of str

    Raises
    ------
    ValueError
        A string, another type, an empty sequence or an unknown name.
    """
    if isinstance(names, str) or not isinstance(names, Sequence) or not names or any(
        n not in _FILLS for n in names
    ):
        raise InvalidInputError(f"{name} must be a non-empty tuple from {AVAILABLE_CANDIDATES}, got {names!r}")
    return tuple(names)


def _nearest_known_columns(known: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Column of the nearest measurement at or left / right of each pixel, per row.

    ``-NO_MEASUREMENT_DISTANCE`` (left) or ``2 * NO_MEASUREMENT_DISTANCE`` (right) where
    the row has none in that direction.
    """
    cols = np.arange(known.shape[1])
    far = NO_MEASUREMENT_DISTANCE
    left = np.maximum.accumulate(np.where(known, cols, -far), axis=1)
    right = np.minimum.accumulate(np.where(known, cols, 2 * far)[:, ::-1], axis=1)[:, ::-1]
    return left, right


def _distances_along_rows(known: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    cols = np.arange(known.shape[1])
    left, right = _nearest_known_columns(known)
    far = NO_MEASUREMENT_DISTANCE
    return np.minimum(cols - left, far), np.minimum(right - cols, far)


def _endpoints_along_rows(values: np.ndarray, known: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    left, right = _nearest_known_columns(known)
    rows = np.arange(known.shape[0])[:, None]
    w = known.shape[1]
    # No measurement in that direction: 0, the "unknown" of the depth convention.
    out_left = np.where(left >= 0, values[rows, np.clip(left, 0, w - 1)], 0.0)
    out_right = np.where(right < w, values[rows, np.clip(right, 0, w - 1)], 0.0)
    return out_left, out_right


def endpoint_values(values: np.ndarray, known: np.ndarray) -> np.ndarray:
    """Depth of the nearest measurement left, right, above and below each pixel.

    The row and column fills interpolate between these; the values themselves tell a
    learned blend whether a gap bridges one surface (similar ends) or a depth edge (a
    near car on one side, a far facade on the other), where interpolation is wrong.

    Parameters
    ----------
    values : numpy.ndarray
        ``(H, W)`` metres, read where ``known``.
    known : numpy.ndarray
        ``(H, W)`` bool.

    Returns
    -------
    numpy.ndarray
        ``(4, H, W)`` float32 metres: left, right, up, down; the pixel's own value on
        measured pixels, 0 where no measurement lies in that direction.
    """
    values, known = _check_values_known(values, known)
    left, right = _endpoints_along_rows(values, known)
    up, down = _endpoints_along_rows(values.T, known.T)
    return np.stack([left, right, up.T, down.T]).astype(np.float32)


def gap_distances(known: np.ndarray) -> np.ndarray:
    """Pixels to the nearest measurement left, right, above and below each pixel.

    Which classical fill to trust depends on the gap it bridges (a row-wise fill is good
    across a narrow, tall hole only if the row gap is short), so a learned blend needs
    these lengths. 0 on measured pixels; :data:`NO_MEASUREMENT_DISTANCE` (capped) where
    none lies in that direction.

    Parameters
    ----------
    known : numpy.ndarray
        ``(H, W)`` bool, True where measured.

    Returns
    -------
    numpy.ndarray
        ``(4, H, W)`` float32: left, right, up, down.
    """
    known = np.asarray(known)
    if known.ndim != 2 or known.dtype != bool:
        raise InvalidInputError(f"known must be a 2-D bool array, got {known.dtype} with shape {known.shape}")
    left, right = _distances_along_rows(known)
    up, down = _distances_along_rows(known.T)
    return np.stack([left, right, up.T, down.T]).astype(np.float32)


#: Fills made from one row (``"row"``) or column (``"col"``) scan; True = inverse depth.
_SCANNED: dict[str, tuple[str, bool]] = {
    "scanline": ("row", False), "scanline-inverse": ("row", True),
    "vertical": ("col", False), "vertical-inverse": ("col", True),
}


class _Scans:
    """The row and column :class:`~estimators._scan.AxisScan` of one frame, each made once."""

    def __init__(self, values: np.ndarray, known: np.ndarray):
        self.values, self.known = values, known
        self._scans: dict[str, AxisScan] = {}

    def get(self, axis: str) -> tuple[AxisScan, np.ndarray]:
        if axis not in self._scans:
            self._scans[axis] = AxisScan(self.known if axis == "row" else self.known.T)
        return self._scans[axis], (self.values if axis == "row" else self.values.T)

    def fill(self, name: str) -> np.ndarray:
        if name not in _SCANNED:
            return _FILLS[name](self.values, self.known)
        axis, inverse = _SCANNED[name]
        scan, values = self.get(axis)
        out = scan.interp_inverse(values) if inverse else scan.interp(values)
        return out if axis == "row" else out.T

    def gaps(self) -> list[np.ndarray]:
        (rows, _), (cols, _) = self.get("row"), self.get("col")
        up, down = cols.gaps(NO_MEASUREMENT_DISTANCE)
        return [*rows.gaps(NO_MEASUREMENT_DISTANCE), up.T, down.T]

    def ends(self) -> list[np.ndarray]:
        (rows, values), (cols, values_t) = self.get("row"), self.get("col")
        up, down = cols.ends(values_t)
        return [*rows.ends(values), up.T, down.T]

    def fills_and_lines(self, names: Sequence[str], gaps: bool = False, endpoints: bool = False) -> list[np.ndarray]:
        """The named fills in order, then the gap and endpoint channels if asked for.

        Whole-frame fills (harmonic, row bands) run in a worker thread while this one
        makes the row/column fills, gaps and endpoints: NumPy and OpenCV release the GIL,
        so on two cores a KITTI frame takes about the longer of the two instead of their
        sum (the features of the five blend candidates: 165 -> 96 ms per 352x1216 frame in
        ``perf/bench_blend.py``, docs/performance.md). The numbers are the same as
        computed one by one.
        """
        def extra() -> list[np.ndarray]:
            return (self.gaps() if gaps else []) + (self.ends() if endpoints else [])

        whole = [n for n in names if n not in _SCANNED]
        if not whole or len(whole) == len(names) and not (gaps or endpoints):
            done = self.whole_fills(whole)  # nothing to overlap
            return [done[n] if n in done else self.fill(n) for n in names] + extra()
        with ThreadPoolExecutor(max_workers=1) as worker:
            pending = worker.submit(self.whole_fills, whole)
            lines = {n: self.fill(n) for n in names if n in _SCANNED}
            lines_extra = extra()
            done = pending.result()
        return [done[n] if n in done else lines[n] for n in names] + lines_extra

    def whole_fills(self, names: Sequence[str]) -> dict[str, np.ndarray]:
        """The named whole-frame fills; the row-context ones from one sort."""
        rows = [n for n in names if n in ROW_QUANTILES]
        done = dict(zip(rows, row_band_quantiles(self.values, self.known, [ROW_QUANTILES[n] for n in rows])))
        return {n: done[n] if n in done else _FILLS[n](self.values, self.known) for n in names}


def candidate_fills(x: np.ndarray, names: Sequence[str] = CANDIDATES) -> np.ndarray:
    """Classical fills of one corrupted frame.

    Parameters
    ----------
    x : numpy.ndarray
        ``(H, W)`` metres; NaN = hole to fill, 0 = no measurement (both unknown).
    names : sequence of str
        Which fills, from :data:`AVAILABLE_CANDIDATES`.

    Returns
    -------
    numpy.ndarray
        ``(len(names), H, W)`` float32 metres, equal to ``x`` where it is measured
        (zeros everywhere if nothing is measured).
    """
    names = check_candidates(names)
    x = check_depth(x, name="x", allow_nan=True, ndim=(2,))
    known = x > 0
    values = np.where(known, x, 0.0).astype(np.float32)
    return np.stack(_Scans(values, known).fills_and_lines(names)).astype(np.float32)


def prior_features(
    x: np.ndarray, names: Sequence[str] = CANDIDATES, gaps: bool = False, endpoints: bool = False
) -> np.ndarray:
    """Network input of one frame: observed depth, hole and validity masks, candidates.

    Parameters
    ----------
    x : numpy.ndarray
        ``(H, W)`` metres; NaN = hole, 0 = no measurement.
    names : sequence of str
        Candidate fills, from :data:`AVAILABLE_CANDIDATES`.
    gaps : bool
        Append the four :func:`gap_distances` channels (pixels).
    endpoints : bool
        Then append the four :func:`endpoint_values` channels (metres).

    Returns
    -------
    numpy.ndarray
        ``(3 + len(names) [+ 4] [+ 4], H, W)`` float32: depth (0 where unknown), hole
        (1/0), valid (1 where measured), the candidate fills in metres, then the gap
        lengths, then the endpoint depths.
    """
    names = check_candidates(names)
    x = check_depth(x, name="x", allow_nan=True, ndim=(2,))
    known = x > 0
    depth = np.where(known, x, 0.0).astype(np.float32)
    # One row and one column scan serve the row/column fills, gaps and endpoints.
    parts = [depth, np.isnan(x), known, *_Scans(depth, known).fills_and_lines(names, gaps, endpoints)]
    out = np.empty((len(parts), *x.shape), np.float32)
    for channel, part in zip(out, parts):
        channel[...] = part
    return out


#: Side (pixels) of the box whose measured share is one of :func:`residual_features`.
DENSITY_BOX = 61


def residual_features(x: np.ndarray, fills: tuple[str, ...], where: Any) -> tuple[np.ndarray, np.ndarray]:
    """The ``(P, C)`` float32 features (NaN -> 0) and the harmonic fill ``(P,)`` of the pixels ``where``.

    Channels: ``harmonic``, then ``fills`` (metres), the four gap lengths (pixels), the four
    endpoint depths (metres), the distance to the nearest measurement (pixels, OpenCV's
    ``DIST_L2`` 5x5 mask) and the measured share of the :data:`DENSITY_BOX` box around the
    pixel (``cv2.blur``). ``x``: one frame in metres, NaN = to fill, 0 = no measurement;
    ``where``: a boolean mask of it or ``(rows, cols)``.
    """
    feats, harmonic = residual_channels(x, fills, where)
    return np.ascontiguousarray(feats.T), harmonic


def _box_channels(pixels: AtPixels, out: np.ndarray) -> None:
    """The distance to the nearest measurement and the measured share of the box, at the pixels into ``out``."""
    unknown = (~pixels.known).astype(np.uint8)
    pixels.at(cv2.distanceTransform(unknown, cv2.DIST_L2, 5), out=out[0])
    pixels.at(cv2.blur((1 - unknown).astype(np.float32), (DENSITY_BOX, DENSITY_BOX)), out=out[1])


def residual_channels(x: np.ndarray, fills: tuple[str, ...], where: Any) -> tuple[np.ndarray, np.ndarray]:
    """:func:`residual_features` pixel last, ``(C, P)``: a network reads a chunk at a time, transposed.

    Made at the pixels with shared pieces (:mod:`estimators._residual_features`); ``harmonic``,
    the longest, runs in a worker thread meanwhile while a core is free
    (:func:`~estimators._residual_features.overlap`).
    """
    names = check_candidates(("harmonic", *fills), "fills")
    x = check_depth(x, name="x", allow_nan=True, ndim=(2,))
    known = x > 0
    values = np.where(known, x, 0.0).astype(np.float32)
    pixels = AtPixels(values, known, flat_pixels(where, x.shape))
    lines = len(GAP_CHANNELS) + len(ENDPOINT_CHANNELS)
    out = np.empty((len(names) + lines + 2, len(pixels.idx)), np.float32)
    scans = _Scans(values, known)
    with overlap() as worker:
        # The worker: harmonic, then the two box channels (about half the work each way).
        pending = worker.submit(lambda: [pixels.at(harmonic_fill(values, known), out=out[0]),
                                         _box_channels(pixels, out[-2:])])
        rows = [n for n in names if n in ROW_QUANTILES]
        done = dict(zip(rows, row_band_quantiles(values, known, [ROW_QUANTILES[n] for n in rows]))) if rows else {}
        made = {"nearest": pixels.nearest, "window-near": lambda: pixels.window(False, WINDOW),
                "window-far": lambda: pixels.window(True, WINDOW)}
        for i, name in enumerate(names[1:], 1):
            if name in done:
                pixels.at(done[name], out=out[i])
            elif name in made:
                out[i] = made[name]()
            elif name != "harmonic":  # another fill, made as prior_features makes it: not always finite
                out[i] = np.nan_to_num(pixels.at(scans.fill(name)), nan=0.0, posinf=0.0, neginf=0.0, copy=False)
        pixels.lines(out[len(names):len(names) + lines], NO_MEASUREMENT_DISTANCE)
        pending.result()
    out[[i for i, n in enumerate(names) if n == "harmonic"]] = out[0]
    return out, out[0].copy()
