"""A sparser LiDAR from a 64-beam scan: keep every k-th laser ring, or a random share of the points.

A spinning LiDAR's lasers each sweep one *ring*: a cone of (nearly) constant elevation. A
32-, 16- or 8-beam sensor sees about every 2nd, 4th or 8th ring of KITTI's HDL-64E, so
keeping every k-th ring of a 64-beam scan simulates it. :func:`laser_rings` finds each
point's ring from its elevation angle in the LiDAR frame:

* the elevation is measured from the lasers' height above the LiDAR origin (the HDL-64E's
  upper block about 0.20 m above the origin of KITTI's Velodyne frame, its lower block
  about 0.13 m, :data:`LASER_HEIGHTS`; measured from the origin, near points of one ring
  smear over the neighbouring rings);
* each ring is followed across azimuth: a ring's elevation drifts with azimuth (on
  2011_09_30 the lower rings tilt by about 0.3 degrees across the image), so the drift of
  each elevation band is fitted (``A (cos a - 1) + B sin a``, the trace of a tilted cone)
  by making that band's elevation histogram sharpest, and the rings are the peaks of the
  histogram of the corrected elevations.

:func:`thin_scan_by_rings` applies it to a projected scan (KITTI's ``velodyne_raw``): each
measured pixel is back-projected into the LiDAR frame with its day's calibration
(:func:`~inpaintenv.data.projection.depth_to_points`), given a ring, and kept when its
ring is a multiple of ``keep_every``. :func:`thin_scan_by_points` keeps a seeded random
share of the measured pixels. Both return a new depth map (metres, 0 = none) and take raw
``.bin`` point clouds too (:func:`thin_points_by_rings`, :func:`thin_points_by_share`).

>>> calib = read_calibration("<KITTI root>/calib/2011_09_30", size=(1226, 370))   # doctest: +SKIP
>>> sixteen = thin_scan_by_rings(scan, calib, keep_every=4)                       # doctest: +SKIP
>>> quarter = thin_scan_by_points(scan, keep_fraction=0.25, seed=0)               # doctest: +SKIP
"""

from __future__ import annotations

import numpy as np

from .calibration import Calibration
from .projection import depth_to_points
from ..exceptions import InvalidInputError

__all__ = [
    "BLOCK_SPLIT_DEG", "LASER_HEIGHTS", "laser_rings", "ring_map", "thin_points_by_rings", "thin_points_by_share", "thin_scan_by_points",
    "thin_scan_by_rings",
]

#: Heights (metres) of the HDL-64E's upper and lower block of lasers above the origin of
#: KITTI's Velodyne frame, measured on the slice's scans as the heights that make each
#: block's ring elevations sharpest: 0.20-0.21 m and 0.12-0.14 m on all three days.
LASER_HEIGHTS: tuple[float, float] = (0.20, 0.13)
#: Elevation (degrees, seen from the upper block's height) between the blocks: the upper
#: block's lowest ring is at about -8.75 degrees, the lower block's highest at -9.45 on all three days.
BLOCK_SPLIT_DEG: float = -9.1

_BIN_DEG = 0.01  # elevation histogram step
_SHARP_BIN_DEG = 0.02  # histogram step of the sharpness a band's drift is fitted by
_SMOOTH_DEG = 0.03  # Gaussian smoothing of the histogram before peaks are found
_MIN_SEPARATION_DEG = 0.2  # two rings of the HDL-64E are at least ~0.3 degrees apart
_BAND_DEG = 3.0  # elevation bands whose drift with azimuth is fitted on their own
_BAND_STEP_DEG = 1.0
_TILT_DEG = 0.5  # the largest drift fitted (degrees at +-90 degrees azimuth)
_SMOOTH_BANDS = 5  # the running median over this many bands a band's drift is refitted near
_REFIT_DEG = 0.1  # how far from that median the refit may go
_MIN_BAND_POINTS = 200
_FIT_POINTS = 2000  # a band's drift is fitted on about this many of its points  # a band with fewer points is not corrected (too few to fit)
_MIN_PEAK_SHARE = 0.02  # a peak below this share of the median peak is noise, not a ring


def _angles(points: np.ndarray, laser_height: float | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Azimuth (radians), elevation (degrees) and block (True: the lower one) of each point.

    ``laser_height`` None: the HDL-64E's two blocks, each from its own height
    (:data:`LASER_HEIGHTS`); a number: one block, from that height.
    """
    xyz = np.asarray(points, dtype=np.float64)
    if xyz.ndim != 2 or xyz.shape[1] not in (3, 4) or not np.isfinite(xyz[:, :3]).all():
        raise InvalidInputError(f"points must be a finite (N, 3) or (N, 4) array, got shape {xyz.shape}")
    x, y, z = xyz[:, 0], xyz[:, 1], xyz[:, 2]
    r = np.hypot(x, y)
    upper_h, lower_h = LASER_HEIGHTS if laser_height is None else (float(laser_height), float(laser_height))
    elevation = np.degrees(np.arctan2(z - upper_h, r))
    # Seen from the upper block's height a lower-block point looks lower still: the split is
    # sure at any range, since the blocks are apart by the gap between them.
    lower = elevation < BLOCK_SPLIT_DEG if laser_height is None else np.zeros(len(z), dtype=bool)
    elevation[lower] = np.degrees(np.arctan2(z[lower] - lower_h, r[lower]))
    return np.arctan2(y, x), elevation, lower


def _sharpness(elevations: np.ndarray) -> np.ndarray:
    """How peaked each row of elevations is: the sum of the squared counts of a fine histogram of the row."""
    bins = np.floor(elevations / _SHARP_BIN_DEG).astype(np.int64)
    bins -= bins.min()
    width = int(bins.max()) + 1
    counts = np.bincount((bins + width * np.arange(len(bins))[:, None]).ravel(), minlength=width * len(bins))
    counts = counts.reshape(len(bins), width).astype(np.float64)
    return np.einsum("ij,ij->i", counts, counts)


def _band_drift(
    azimuth: np.ndarray, elevation: np.ndarray, start: tuple[float, float] = (0.0, 0.0), reach: float = _TILT_DEG,
) -> tuple[float, float]:
    """``(A, B)`` of the drift ``A (cos a - 1) + B sin a`` within ``reach`` of ``start`` that makes the band's rings
    sharpest (searched coarse to fine, every candidate of a step scored at once)."""
    stride = max(1, len(elevation) // _FIT_POINTS)  # a fixed share of the band: deterministic, and as sharp
    azimuth, elevation = azimuth[::stride], elevation[::stride]
    basis = np.stack([np.cos(azimuth) - 1.0, np.sin(azimuth)])
    best = np.array(start, dtype=np.float64)
    for steps, step in ((5, reach / 5), (2, reach / 20), (2, reach / 80)):
        offsets = np.arange(-steps, steps + 1) * step
        grid = best + np.stack(np.meshgrid(offsets, offsets, indexing="ij"), axis=-1).reshape(-1, 2)
        scores = _sharpness(elevation[None, :] - grid @ basis)
        best = grid[int(np.argmax(scores))]  # ties: the first, the smallest drift of the grid's order
    return float(best[0]), float(best[1])


def _corrected(azimuth: np.ndarray, elevation: np.ndarray) -> np.ndarray:
    """The elevations with each band's drift across azimuth removed (bands blended by elevation).

    Each band is fitted on its own, then again near the running median of its neighbours'
    fits: a band of evenly spaced rings can also look sharp tilted by one ring spacing
    across the image, which no real sensor's neighbouring rings do.
    """
    centres = np.arange(np.floor(elevation.min()), np.ceil(elevation.max()) + _BAND_STEP_DEG, _BAND_STEP_DEG)
    bands = [(c, np.abs(elevation - c) < _BAND_DEG / 2) for c in centres]
    bands = [(c, inside) for c, inside in bands if np.count_nonzero(inside) >= _MIN_BAND_POINTS]
    if not bands:
        return elevation.copy()
    first = np.array([_band_drift(azimuth[inside], elevation[inside]) for _, inside in bands])
    half = _SMOOTH_BANDS // 2
    shift, weight = np.zeros_like(elevation), np.zeros_like(elevation)
    for j, (c, inside) in enumerate(bands):
        near = np.median(first[max(0, j - half): j + half + 1], axis=0)
        a, b = _band_drift(azimuth[inside], elevation[inside], (near[0], near[1]), _REFIT_DEG)
        w = 1.0 - np.abs(elevation[inside] - c) / (_BAND_DEG / 2)  # triangular: bands blend smoothly
        shift[inside] += w * (a * (np.cos(azimuth[inside]) - 1.0) + b * np.sin(azimuth[inside]))
        weight[inside] += w
    return elevation - np.divide(shift, weight, out=np.zeros_like(shift), where=weight > 0)


def _ring_edges(elevation: np.ndarray) -> np.ndarray:
    """Elevations separating the rings, descending: the lowest point of the smoothed histogram between two peaks."""
    lo = elevation.min() - 5 * _SMOOTH_DEG
    top = int((elevation.max() + 5 * _SMOOTH_DEG - lo) / _BIN_DEG) + 1  # margins both sides: end rings are peaks too
    counts = np.bincount(((elevation - lo) / _BIN_DEG).astype(np.int64), minlength=top).astype(np.float64)
    half = int(4 * _SMOOTH_DEG / _BIN_DEG)
    kernel = np.exp(-0.5 * (np.arange(-half, half + 1) * _BIN_DEG / _SMOOTH_DEG) ** 2)
    hist = np.convolve(np.pad(counts, half), kernel, mode="valid")
    inner = hist[1:-1]
    peaks = np.flatnonzero((inner > hist[:-2]) & (inner >= hist[2:])) + 1
    if len(peaks) == 0:
        return np.zeros(0)
    peaks = peaks[hist[peaks] >= _MIN_PEAK_SHARE * np.median(hist[peaks])]
    # Greedily keep the highest peaks at least _MIN_SEPARATION_DEG apart.
    kept: list[int] = []
    sep = int(round(_MIN_SEPARATION_DEG / _BIN_DEG))
    for p in peaks[np.argsort(-hist[peaks], kind="stable")]:
        if all(abs(p - q) >= sep for q in kept):
            kept.append(int(p))
    kept.sort()
    valleys = [a + int(np.argmin(hist[a:b])) for a, b in zip(kept[:-1], kept[1:])]
    return (lo + (np.asarray(valleys, dtype=np.float64) + 0.5) * _BIN_DEG)[::-1]


def laser_rings(points: np.ndarray, laser_height: float | None = None) -> np.ndarray:
    """The laser ring of each point of a spinning LiDAR's scan, from its elevation.

    Parameters
    ----------
    points : numpy.ndarray
        ``(N, 3)`` or ``(N, 4)`` x, y, z (metres, the LiDAR frame: x forward, y left, z up).
    laser_height : float, optional
        Height (metres) above the origin from which elevations are measured, for a sensor
        with one block of lasers (0 when its origin is its lasers'). None (the default):
        KITTI's HDL-64E, its two blocks each from its own height (:data:`LASER_HEIGHTS`).

    Returns
    -------
    numpy.ndarray
        ``(N,)`` int64: 0 for the highest ring found, 1 for the next below, ... Rings are
        counted among those the points show (a ring with no point is not counted).

    Raises
    ------
    InvalidInputError
        Points that are not a finite ``(N, 3)`` or ``(N, 4)`` array.
    """
    azimuth, elevation, lower = _angles(points, laser_height)
    if len(elevation) == 0:
        return np.zeros(0, dtype=np.int64)
    corrected = np.empty_like(elevation)
    for block in (lower, ~lower):  # each block of lasers drifts on its own
        if block.any():
            corrected[block] = _corrected(azimuth[block], elevation[block])
    edges = _ring_edges(corrected)
    # edges descend: a point above the first edge is ring 0.
    return np.searchsorted(-edges, -corrected, side="left").astype(np.int64)


def _check_keep_every(keep_every: object) -> int:
    if isinstance(keep_every, bool) or not isinstance(keep_every, (int, np.integer)) or int(keep_every) < 1:
        raise InvalidInputError(f"keep_every must be a whole number of rings of at least 1, got {keep_every!r}")
    return int(keep_every)


def _check_fraction(keep_fraction: object) -> float:
    if isinstance(keep_fraction, bool) or not isinstance(keep_fraction, (int, float, np.floating, np.integer)) \
            or not 0.0 < float(keep_fraction) <= 1.0:
        raise InvalidInputError(f"keep_fraction must be a share of the points in (0, 1], got {keep_fraction!r}")
    return float(keep_fraction)


def _check_scan(scan_depth: np.ndarray) -> np.ndarray:
    d = np.asarray(scan_depth)
    if d.ndim != 2 or not np.issubdtype(d.dtype, np.floating):
        raise InvalidInputError(f"a scan depth map is a float (H, W) array, got {d.dtype} of shape {d.shape}")
    return d


def ring_map(scan_depth: np.ndarray, calibration: Calibration, laser_height: float | None = None) -> np.ndarray:
    """The laser ring of each measured pixel of a projected scan, -1 where none.

    Parameters
    ----------
    scan_depth : numpy.ndarray
        ``(H, W)`` float metres, 0 (or NaN) = no measurement: a projected single scan
        (KITTI's ``velodyne_raw``).
    calibration : Calibration
        The projection the map was made with (its day's; see
        :func:`~inpaintenv.data.calibration.read_calibration`).
    laser_height : float, optional
        As :func:`laser_rings`.

    Returns
    -------
    numpy.ndarray
        ``(H, W)`` int64.
    """
    d = _check_scan(scan_depth)
    with np.errstate(invalid="ignore"):
        measured = np.isfinite(d) & (d > 0)
    rings = np.full(d.shape, -1, dtype=np.int64)
    rings[measured] = laser_rings(depth_to_points(d, calibration, measured), laser_height)  # row-major both
    return rings


def thin_scan_by_rings(
    scan_depth: np.ndarray, calibration: Calibration, keep_every: int, laser_height: float | None = None,
) -> np.ndarray:
    """A projected scan with only every ``keep_every``-th laser ring kept (2, 4, 8: 32, 16, 8 of 64 beams).

    Rings 0, k, 2k, ... (counted from the highest ring found, :func:`laser_rings`) are kept;
    the other pixels become 0.

    Parameters
    ----------
    scan_depth : numpy.ndarray
        ``(H, W)`` float metres, 0 (or NaN) = no measurement.
    calibration : Calibration
        The projection the map was made with.
    keep_every : int
        Keep one ring in this many (1 keeps the scan as it is).
    laser_height : float, optional
        As :func:`laser_rings`.

    Returns
    -------
    numpy.ndarray
        ``(H, W)`` of ``scan_depth``'s dtype, a new array.

    Raises
    ------
    InvalidInputError
        ``keep_every`` not a whole number of at least 1, or ``scan_depth`` not a float ``(H, W)`` array.
    CalibrationError
        A calibration that back-projects to non-finite points.
    """
    k = _check_keep_every(keep_every)
    d = _check_scan(scan_depth)
    out = np.array(d, copy=True)
    rings = ring_map(d, calibration, laser_height)
    out[(rings < 0) | (rings % k != 0)] = 0
    return out


def _share_kept(n: int, keep_fraction: float, seed: int) -> np.ndarray:
    """A boolean mask keeping ``round(keep_fraction * n)`` of ``n`` items, chosen by ``seed``."""
    keep = np.zeros(n, dtype=bool)
    keep[np.random.default_rng(seed).permutation(n)[: int(round(keep_fraction * n))]] = True
    return keep


def _check_seed(seed: object) -> int:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or int(seed) < 0:
        raise InvalidInputError(f"seed must be a non-negative integer, got {seed!r}")
    return int(seed)


def thin_scan_by_points(scan_depth: np.ndarray, keep_fraction: float, seed: int) -> np.ndarray:
    """A projected scan with a seeded random share of its measured pixels kept (0.5, 0.25, 0.1 ...).

    Parameters
    ----------
    scan_depth : numpy.ndarray
        ``(H, W)`` float metres, 0 (or NaN) = no measurement.
    keep_fraction : float
        The share of measured pixels kept, in (0, 1]; exactly ``round(keep_fraction * n)`` of ``n``.
    seed : int
        The same seed and scan keep the same pixels.

    Returns
    -------
    numpy.ndarray
        ``(H, W)`` of ``scan_depth``'s dtype, a new array (the pixels not kept are 0).
    """
    f, s = _check_fraction(keep_fraction), _check_seed(seed)
    d = _check_scan(scan_depth)
    with np.errstate(invalid="ignore"):
        measured = np.flatnonzero(np.isfinite(d) & (d > 0))
    out = np.zeros_like(d)
    kept = measured[_share_kept(len(measured), f, s)]
    out.ravel()[kept] = d.ravel()[kept]
    return out


def thin_points_by_rings(points: np.ndarray, keep_every: int, laser_height: float | None = None) -> np.ndarray:
    """The points of a raw scan (``.bin``, ``(N, 3)`` or ``(N, 4)``) on every ``keep_every``-th ring, in their order.

    Checked within a camera's view (about +-45 degrees of azimuth). Over a whole 360-degree
    sweep the drift of a 2011_09_30 scan's lower rings is not a tilted cone's (up to about
    1 degree behind the car), and some of them split (74 rings found in an odometry sequence
    05 scan; 64 in a 2011_09_26 raw and a KITTI-360 scan): thin the points in the camera's
    view, or the projected scan (:func:`thin_scan_by_rings`), for those.
    """
    k = _check_keep_every(keep_every)
    return np.asarray(points)[laser_rings(points, laser_height) % k == 0]


def thin_points_by_share(points: np.ndarray, keep_fraction: float, seed: int) -> np.ndarray:
    """A seeded random ``keep_fraction`` of the points of a raw scan, in their order."""
    pts = np.asarray(points)
    return pts[_share_kept(len(pts), _check_fraction(keep_fraction), _check_seed(seed))]
