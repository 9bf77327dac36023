"""One scan per axis for every row/column feature of :mod:`estimators.candidates`.

The row-wise and column-wise candidate fills (depth and inverse depth), the gap lengths
and the endpoint depths all start from the same thing: the nearest measurement before
and after each pixel along an axis. Computed once per axis here and shared, they cost
about a third of computing each feature on its own, with the same numbers as
:func:`estimators.classical.scanline.scanline_fill`,
:func:`estimators.classical._base.in_inverse_depth`,
:func:`estimators.candidates.gap_distances` and :func:`estimators.candidates.endpoint_values`
(checked by ``tests/estimators/classical/test_scan.py``).
"""

from __future__ import annotations

import numpy as np

__all__ = ["AxisScan", "fill_empty_rows"]


class AxisScan:
    """Nearest measurement at or before / at or after each pixel along axis 1.

    Parameters
    ----------
    known : numpy.ndarray
        ``(H, W)`` bool, True where measured (transpose it to scan columns).
    """

    def __init__(self, known: np.ndarray):
        h, w = known.shape
        cols = np.arange(w, dtype=np.int32)
        self.known = known
        self.width = w
        self.cols = cols
        # -1 / w mark "no measurement on that side".
        self.left = np.maximum.accumulate(np.where(known, cols, np.int32(-1)), axis=1)
        self.right = np.minimum.accumulate(np.where(known, cols, np.int32(w))[:, ::-1], axis=1)[:, ::-1]
        self.has_left = self.left >= 0
        self.has_right = self.right < w
        self.line_ok = self.has_left[:, -1]  # the line holds at least one measurement
        # Flat indices of the two measurements: one np.take per array gathers them.
        row_start = (np.arange(h, dtype=np.int64) * w)[:, None]
        self._left_flat = row_start + np.maximum(self.left, 0)
        self._right_flat = row_start + np.minimum(self.right, w - 1)
        span = np.maximum(self.right - self.left, 1).astype(np.float32)
        self._t = (cols - self.left).astype(np.float32) / span
        self._ends: tuple[np.ndarray, np.ndarray] | None = None
        self._ends_of: tuple | None = None

    def gaps(self, far: int) -> tuple[np.ndarray, np.ndarray]:
        """Pixels to the nearest measurement before / after, capped at ``far``."""
        before = np.where(self.has_left, np.minimum(self.cols - self.left, far), far)
        after = np.where(self.has_right, np.minimum(self.right - self.cols, far), far)
        return before.astype(np.float32), after.astype(np.float32)

    def _gather(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``values`` at the measurement before / after each pixel.

        The callers of one scan pass the same measured depth (a view of one buffer), so
        the gather is made once and reused while the buffer is the same.
        """
        key = (values.__array_interface__["data"][0], values.shape, values.strides)
        if self._ends is None or self._ends_of != key:
            flat = np.ravel(values)
            self._ends, self._ends_of = (np.take(flat, self._left_flat), np.take(flat, self._right_flat)), key
        return self._ends

    def ends(self, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Depth of the nearest measurement before / after (0 where none)."""
        v_left, v_right = self._gather(values)
        return np.where(self.has_left, v_left, 0.0), np.where(self.has_right, v_right, 0.0)

    def _interp_ends(self, v_left: np.ndarray, v_right: np.ndarray) -> np.ndarray:
        # Open-ended gaps repeat their one measured end.
        v_left, v_right = np.where(self.has_left, v_left, v_right), np.where(self.has_right, v_right, v_left)
        # On a measured pixel left = right = itself and t = 0: its own value, exactly.
        out = v_left + self._t * (v_right - v_left)
        if not self.line_ok.all():
            out = fill_empty_rows(out, self.line_ok)
        return out

    def interp(self, values: np.ndarray) -> np.ndarray:
        """Linear interpolation between the nearest measurements (``float32`` ``values``).

        Open-ended gaps repeat their one measured end; lines without any measurement are
        then interpolated across the nearest filled lines (as ``scanline_fill`` does).
        ``values`` must be the measured depth this scan's callers share (0 where unknown).
        """
        return np.where(self.known, values, self._interp_ends(*self._gather(values)))

    def interp_inverse(self, values: np.ndarray) -> np.ndarray:
        """:meth:`interp` of inverse depth, returned as depth (0 where nothing is known)."""
        # Inverse depth of the two measurements, as in_inverse_depth computes it (float64
        # division, float32 result); the gathered ends are measured pixels, or unused.
        inv_left, inv_right = (
            np.divide(1.0, v, out=np.zeros(v.shape), where=has).astype(np.float32)
            for v, has in zip(self._gather(values), (self.has_left, self.has_right))
        )
        filled = self._interp_ends(inv_left, inv_right)
        depth = np.divide(1.0, filled, out=np.zeros(values.shape), where=filled > 0)
        return np.where(self.known, values, depth).astype(np.float32)


def fill_empty_rows(filled: np.ndarray, row_ok: np.ndarray) -> np.ndarray:
    """Rows with ``row_ok`` False, linearly interpolated between the nearest ok rows.

    Rows before the first / after the last ok row repeat it.
    """
    h = filled.shape[0]
    rows = np.arange(h)
    ok = np.flatnonzero(row_ok)
    if len(ok) == 0:
        return filled
    below = np.maximum.accumulate(np.where(row_ok, rows, -1))
    above = np.minimum.accumulate(np.where(row_ok, rows, h)[::-1])[::-1]
    has_b, has_a = below >= 0, above < h
    b = np.where(has_b, below, above)
    a = np.where(has_a, above, below)
    span = np.maximum(a - b, 1).astype(np.float32)
    t = ((rows - b).astype(np.float32) / span)[:, None]
    # Only the empty rows are computed: KITTI frames have a few (the sky), not a whole frame's worth.
    bad = np.flatnonzero(~row_ok)
    out = filled.copy()
    low, high = filled[b[bad]], filled[a[bad]]
    out[bad] = low + t[bad] * (high - low)
    return out
