"""Scanline fill: interpolate each image row across its gaps (depth or inverse depth)."""

from __future__ import annotations

import numpy as np

from .._constraints import Bool
from ._base import ClassicalInpainter, in_inverse_depth, unknown_mask

__all__ = ["ScanlineInpainter", "scanline_fill"]


def _interp_along_rows(
    values: np.ndarray, known: np.ndarray, *, with_gap: bool = False
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
    """Linear interpolation along axis 1 between the nearest known pixels left and right.

    Pixels before the first / after the last known pixel of a row take that pixel's
    value. Returns the filled array, (if ``with_gap``) the length of the gap each pixel
    lies in (``inf`` in a row without any known pixel), and a per-row flag "row had a
    known pixel".
    """
    w = values.shape[1]
    cols = np.arange(w, dtype=np.int32)
    # Index of the nearest known pixel at or left of each column (-1: none) ...
    left = np.maximum.accumulate(np.where(known, cols, np.int32(-1)), axis=1)
    # ... and at or right of it (w: none).
    right = np.minimum.accumulate(np.where(known, cols, np.int32(w))[:, ::-1], axis=1)[:, ::-1]
    has_left, has_right = left >= 0, right < w
    v_left = np.take_along_axis(values, np.maximum(left, 0), axis=1)
    v_right = np.take_along_axis(values, np.minimum(right, w - 1), axis=1)
    # Open-ended gaps (image border) repeat their one known end.
    v_left = np.where(has_left, v_left, v_right)
    v_right = np.where(has_right, v_right, v_left)
    span = np.maximum(right - left, 1).astype(values.dtype)
    t = (cols - left).astype(values.dtype) / span
    out = v_left + t * (v_right - v_left)
    row_ok = known.any(axis=1)
    gap = None
    if with_gap:
        # An open-ended gap counts as twice the distance to its one end.
        gap = np.where(
            has_left & has_right, right - left,
            np.where(has_left, 2 * (cols - left), 2 * (right - cols)),
        ).astype(np.float32)
        gap[~row_ok] = np.inf
    return out, gap, row_ok


def scanline_fill(values: np.ndarray, known: np.ndarray, vertical: bool = False) -> np.ndarray:
    """Fill unknown pixels row by row, then rows without any known pixel column-wise.

    Parameters
    ----------
    values : numpy.ndarray
        ``(H, W)``; only read where ``known``.
    known : numpy.ndarray
        ``(H, W)`` bool.
    vertical : bool
        Also interpolate along columns and blend both directions, each weighted by the
        inverse length of the gap it bridges (the shorter gap is the better guess).

    Returns
    -------
    numpy.ndarray
        float32 ``(H, W)``, equal to ``values`` where known; zeros if nothing is known.
    """
    if not known.any():
        return np.zeros(values.shape, np.float32)
    vals = np.where(known, values, 0.0).astype(np.float32)
    rows_filled, row_gap, row_ok = _interp_along_rows(vals, known, with_gap=vertical)
    if not row_ok.all():
        # Empty rows: interpolate vertically between the nearest filled rows, i.e.
        # the same scan along columns with whole rows as known.
        col_known = np.broadcast_to(row_ok[:, None], known.shape)
        cols_filled, _, _ = _interp_along_rows(rows_filled.T, col_known.T)
        rows_filled = cols_filled.T
    if vertical:
        cols_filled, col_gap, _ = _interp_along_rows(vals.T, known.T, with_gap=True)
        w_row = 1.0 / np.maximum(row_gap, 1.0)  # 0 in an empty row (gap = inf)
        w_col = 1.0 / np.maximum(col_gap.T, 1.0)
        w_sum = w_row + w_col
        blended = np.divide(
            w_row * rows_filled + w_col * cols_filled.T, w_sum,
            out=rows_filled.copy(), where=w_sum > 0,
        )
        rows_filled = blended
    return np.where(known, vals, rows_filled)


class ScanlineInpainter(ClassicalInpainter):
    """Interpolate each row linearly across every gap between its nearest measurements.

    In driving scenes depth varies mostly along image rows (ground plane, horizon,
    facades), so a row-wise interpolation is a strong and very fast prior for large
    occlusions. Beyond the first/last measurement of a row the nearest measurement is
    repeated; rows without any measurement are interpolated vertically between the
    nearest filled rows.

    Parameters
    ----------
    inverse : bool, default=False
        Interpolate inverse depth (disparity-like, linear along planes seen in
        perspective) instead of depth.
    vertical : bool, default=False
        Also interpolate along columns and blend the two, each weighted by the inverse
        length of the gap it bridges (a 2-D variant: tall, narrow holes are bridged
        vertically).
    keep_observed : bool, default=True
        Return measured input pixels unchanged.
    n_jobs : int or None, default=None
        Frames processed in parallel (joblib; None = 1, -1 = all cores).
    """

    def __init__(
        self, *, inverse: bool = False, vertical: bool = False, keep_observed: bool = True,
        n_jobs: int | None = None,
    ):
        self.inverse = inverse
        self.vertical = vertical
        self.keep_observed = keep_observed
        self.n_jobs = n_jobs

    _parameter_constraints = {
        **ClassicalInpainter._parameter_constraints,
        "inverse": [Bool()],
        "vertical": [Bool()],
    }

    def _fill_frame(self, x: np.ndarray) -> np.ndarray:
        known = ~unknown_mask(x)
        if not self.inverse:
            return scanline_fill(x, known, self.vertical).astype(np.float32)
        return in_inverse_depth(scanline_fill, x, known, self.vertical)
