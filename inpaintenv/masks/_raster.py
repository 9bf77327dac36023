"""Vectorised NumPy rasterisers shared by the protocols (private).

Every shape is drawn as a set of 1-pixel-thick *intervals* (a run of pixels along one
row or one column) and all intervals are filled at once with a difference array and a
cumulative sum. That is O(H·W) per mask whatever the number of shapes, pure NumPy (so
a mask depends only on NumPy's random stream, not on a drawing library's rasteriser),
and fast enough for hundreds of 352×1216 masks per second.
"""

from __future__ import annotations

import numpy as np

__all__ = ["capsule_intervals", "disc_intervals", "fill_intervals", "smooth_noise"]


def fill_intervals(
    shape: tuple[int, int],
    line: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    *,
    axis: int = 1,
) -> np.ndarray:
    """Boolean mask that is True on the union of closed pixel intervals.

    Parameters
    ----------
    shape : (int, int)
        ``(H, W)`` of the mask.
    line : array of int
        For ``axis=1`` the row of each interval, for ``axis=0`` its column.
    lo, hi : array of float or int
        First and last pixel (inclusive) of each interval along ``axis``; rounded to
        the nearest pixel. Parts outside the image are clipped and empty intervals
        (``hi < lo`` or off the image) are dropped.
    axis : {0, 1}
        1: intervals run along rows (horizontal runs); 0: along columns (vertical).

    Returns
    -------
    numpy.ndarray
        ``(H, W)`` bool.
    """
    H, W = shape
    n_lines, length = (H, W) if axis == 1 else (W, H)
    line = np.asarray(line, dtype=np.int64).ravel()
    lo = np.rint(np.asarray(lo, dtype=np.float64)).ravel()
    hi = np.rint(np.asarray(hi, dtype=np.float64)).ravel()
    line, lo, hi = np.broadcast_arrays(line, lo, hi)
    keep = (line >= 0) & (line < n_lines) & (hi >= 0) & (lo <= length - 1) & (hi >= lo)
    line = line[keep]
    lo = np.clip(lo[keep], 0, length - 1).astype(np.int64)
    hi = np.clip(hi[keep], 0, length - 1).astype(np.int64) + 1
    # Difference array in image layout with one extra position for hi + 1, summed in
    # place along the runs' direction. One np.add.at on flat indices with int32 values
    # of the array's own dtype hits NumPy's fast path (scalar or int64 values do not,
    # and np.bincount's int64 output of H·W entries costs more than the fill itself).
    n = line.size
    step = np.concatenate([np.ones(n, dtype=np.int32), np.full(n, -1, dtype=np.int32)])
    if axis == 1:
        diff = np.zeros((H, W + 1), dtype=np.int32)
        flat = np.concatenate([line * (W + 1) + lo, line * (W + 1) + hi])
        np.add.at(diff.reshape(-1), flat, step)
        np.cumsum(diff, axis=1, out=diff)
        return diff[:, :W] > 0
    diff = np.zeros((H + 1, W), dtype=np.int32)
    flat = np.concatenate([lo * W + line, hi * W + line])
    np.add.at(diff.reshape(-1), flat, step)
    np.cumsum(diff, axis=0, out=diff)
    return diff[:H] > 0


def disc_intervals(
    cy: np.ndarray, cx: np.ndarray, r: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Row intervals covering discs of centres ``(cy, cx)`` and radii ``r`` (vectorised).

    Returns
    -------
    row, lo, hi : numpy.ndarray
        One interval per (disc, row) pair; rows a disc only grazes come out empty
        (``hi < lo``), which :func:`fill_intervals` drops.
    disc : numpy.ndarray
        Index of the disc each interval belongs to.
    """
    cy = np.asarray(cy, dtype=np.float64).ravel()
    cx = np.asarray(cx, dtype=np.float64).ravel()
    r = np.maximum(np.asarray(r, dtype=np.float64).ravel(), 0.5)
    half_rows = np.ceil(r).astype(np.int64)
    n_rows = 2 * half_rows + 1
    disc = np.repeat(np.arange(cy.size), n_rows)
    start = np.cumsum(n_rows) - n_rows
    offset = np.arange(disc.size) - start[disc] - half_rows[disc]
    row = np.rint(cy)[disc] + offset
    half2 = r[disc] ** 2 - (row - cy[disc]) ** 2
    half = np.sqrt(np.maximum(half2, 0.0))
    inside = half2 >= 0
    lo = np.where(inside, cx[disc] - half, 1.0)
    hi = np.where(inside, cx[disc] + half, 0.0)
    return row.astype(np.int64), lo, hi, disc


def capsule_intervals(
    p0: np.ndarray, p1: np.ndarray, r: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Row intervals covering thick segments (capsules: points within ``r`` of ``p0``-``p1``).

    A capsule is convex, so each row meets it in one interval, whose ends are the
    extreme points among the two end discs' row slices and the crossings of the row
    with the two straight sides (when they fall within the segment). One interval per
    (capsule, row) pair -- far fewer than stamping discs along the segment.

    Parameters
    ----------
    p0, p1 : numpy.ndarray
        ``(n, 2)`` segment ends as ``(y, x)``.
    r : numpy.ndarray
        ``(n,)`` radii (half the stroke width).

    Returns
    -------
    row, lo, hi, capsule : numpy.ndarray
        Intervals as for :func:`disc_intervals`, with the capsule each belongs to.
    """
    p0 = np.asarray(p0, dtype=np.float64).reshape(-1, 2)
    p1 = np.asarray(p1, dtype=np.float64).reshape(-1, 2)
    r = np.maximum(np.asarray(r, dtype=np.float64).ravel(), 0.5)
    top = np.floor(np.minimum(p0[:, 0], p1[:, 0]) - r).astype(np.int64)
    bottom = np.ceil(np.maximum(p0[:, 0], p1[:, 0]) + r).astype(np.int64)
    n_rows = bottom - top + 1
    cap = np.repeat(np.arange(r.size), n_rows)
    row = top[cap] + np.arange(cap.size) - (np.cumsum(n_rows) - n_rows)[cap]
    y = row.astype(np.float64)
    rr = r[cap]
    lo = np.full(y.shape, np.inf)
    hi = np.full(y.shape, -np.inf)
    for end in (p0, p1):  # end discs
        h2 = rr**2 - (y - end[cap, 0]) ** 2
        ok = h2 >= 0
        h = np.sqrt(np.where(ok, h2, 0.0))
        lo = np.where(ok, np.minimum(lo, end[cap, 1] - h), lo)
        hi = np.where(ok, np.maximum(hi, end[cap, 1] + h), hi)
    d = p1 - p0
    length = np.hypot(d[:, 0], d[:, 1])
    slanted = length > 0
    u = np.where(slanted[:, None], d / np.where(slanted, length, 1.0)[:, None], 0.0)
    normal = np.stack([-u[:, 1], u[:, 0]], axis=1)
    for sign in (1.0, -1.0):  # the two straight sides
        oy = p0[cap, 0] + sign * rr * normal[cap, 0]
        ox = p0[cap, 1] + sign * rr * normal[cap, 1]
        uy, ux = u[cap, 0], u[cap, 1]
        steep = np.abs(uy) > 1e-9
        s = (y - oy) / np.where(steep, uy, 1.0)
        ok = steep & (s >= 0) & (s <= length[cap])
        x = ox + s * ux
        lo = np.where(ok, np.minimum(lo, x), lo)
        hi = np.where(ok, np.maximum(hi, x), hi)
    empty = ~np.isfinite(lo)
    lo = np.where(empty, 1.0, lo)
    hi = np.where(empty, 0.0, hi)
    return row, lo, hi, cap


def _interp_weights(n_out: int, n_in: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Indices and weights for linear interpolation of ``n_in`` samples onto ``n_out`` (centres aligned)."""
    pos = np.clip((np.arange(n_out) + 0.5) * (n_in / n_out) - 0.5, 0, n_in - 1)
    i0 = np.floor(pos).astype(np.int64)
    i1 = np.minimum(i0 + 1, n_in - 1)
    return i0, i1, (pos - i0).astype(np.float32)


def smooth_noise(shape: tuple[int, int], rng: np.random.Generator, cell: float) -> np.ndarray:
    """Smooth random field: Gaussian noise on a grid of ``cell``-pixel cells, bilinearly upsampled.

    Parameters
    ----------
    shape : (int, int)
        ``(H, W)`` of the output.
    rng : numpy.random.Generator
        Source of the grid values.
    cell : float
        Correlation length in pixels (grid spacing), > 0.

    Returns
    -------
    numpy.ndarray
        ``(H, W)`` float32 field, zero mean and unit variance at the grid nodes.
    """
    H, W = shape
    gh = max(2, int(np.ceil(H / cell)) + 1)
    gw = max(2, int(np.ceil(W / cell)) + 1)
    grid = rng.standard_normal((gh, gw)).astype(np.float32)
    # Separable bilinear upsampling: columns first on the tiny grid, then whole-row
    # gathers (contiguous copies) -- faster than gathering columns of a full frame, and
    # no BLAS call, whose threads only add overhead at this size.
    x0, x1, fx = _interp_weights(W, gw)
    cols = grid[:, x0] * (1 - fx) + grid[:, x1] * fx  # (gh, W)
    y0, y1, fy = _interp_weights(H, gh)
    fy = fy[:, None]
    out = np.take(cols, y0, axis=0)
    out *= 1 - fy
    lower = np.take(cols, y1, axis=0)
    lower *= fy
    out += lower
    return out
