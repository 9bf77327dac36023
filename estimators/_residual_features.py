"""The shared pieces of :func:`estimators.candidates.residual_features`, at the pixels asked for (no torch).

A sparse scan leaves ~95 % of a frame to fill, so each channel stays one whole-frame operation
and one gather; what these pieces save is repeated work and whole-frame copies. One distance
transform with labels gives the nearest measurement that the ``nearest`` fill and both window
fills' empty windows read (each computed it again), one cumulative scan per direction gives the
gap lengths and endpoint depths (without the interpolation weights a row/column fill needs), and
each channel is gathered as soon as it is made instead of from a stack of whole frames. The
numbers are those of :func:`~estimators.classical.nearest.nearest_fill`,
:func:`~estimators.candidates.window_extreme`, :func:`~estimators.candidates.gap_distances` and
:func:`~estimators.candidates.endpoint_values` (``tests/estimators/test_residual_features.py``
recomputes every channel from its definition).
"""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np

from inpaintenv.exceptions import InvalidInputError

__all__ = ["AtPixels", "flat_pixels"]


def flat_pixels(where: Any, shape: tuple[int, int]) -> np.ndarray:
    """Flat indices of ``where`` (a boolean mask of ``shape`` or ``(rows, cols)``), in its order."""
    if isinstance(where, tuple):
        try:
            return np.ravel_multi_index(tuple(np.asarray(w) for w in where), shape)
        except (TypeError, ValueError) as err:
            raise InvalidInputError(f"where must be (rows, cols) of pixels inside the {shape} frame: {err}") from None
    mask = np.asarray(where)
    if mask.dtype != bool or mask.shape != shape:
        raise InvalidInputError(f"where must be a {shape} bool mask or (rows, cols), got {mask.dtype} {mask.shape}")
    return np.flatnonzero(mask)


class AtPixels:
    """One frame's measurements and the pixels asked for; the shared pieces are made once."""

    def __init__(self, values: np.ndarray, known: np.ndarray, idx: np.ndarray):
        self.values, self.known, self.idx = values, known, idx
        self.known_at, self.values_at = self.at(known), self.at(values)
        self._nearest: np.ndarray | None = None

    def at(self, image: np.ndarray) -> np.ndarray:
        return np.take(image.ravel(), self.idx)

    def nearest(self) -> np.ndarray:
        """:func:`~estimators.classical.nearest.nearest_fill` at the pixels."""
        if self._nearest is None:
            if not self.known.any():
                self._nearest = np.zeros(len(self.idx), np.float32)
            elif self.known.all():
                self._nearest = self.values_at.copy()
            else:
                # DIST_LABEL_PIXEL numbers the measured pixels 1..K in raster order, as values[known].
                _, labels = cv2.distanceTransformWithLabels((~self.known).astype(np.uint8), cv2.DIST_L2, 5,
                                                            labelType=cv2.DIST_LABEL_PIXEL)
                self._nearest = self.values[self.known][self.at(labels) - 1]
        return self._nearest

    def window(self, far: bool, size: int) -> np.ndarray:
        """:func:`~estimators.candidates.window_extreme` at the pixels."""
        if not self.known.any():
            return np.zeros(len(self.idx), np.float32)
        kernel = np.ones((size, size), np.uint8)
        if far:
            out = self.at(cv2.dilate(np.where(self.known, self.values, 0.0).astype(np.float32), kernel))
            empty = out <= 0
        else:
            # OpenCV pads an erosion with the type's largest value: anything that high is empty.
            out = self.at(cv2.erode(np.where(self.known, self.values, np.inf).astype(np.float32), kernel))
            empty = ~(out < np.finfo(np.float32).max)
        if empty.any():
            out = np.where(empty, self.nearest(), out)
        return np.where(self.known_at, self.values_at, out)

    def lines(self, out: np.ndarray, far: int) -> None:
        """Gap lengths (capped at ``far``) then endpoint depths, left, right, up, down, at the
        pixels into ``out`` ``(8, P)`` (:func:`~estimators.candidates.gap_distances`,
        :func:`~estimators.candidates.endpoint_values`)."""
        h, w = self.known.shape
        # The depth framed by a zero row above and below and a zero column after each row:
        # "no measurement" (row or column -1, or h / w) reads 0 there.
        padded = np.zeros((h + 2, w + 1), np.float32)
        padded[1:-1, :w] = self.values
        padded = padded.ravel()
        rows, cols = (a.astype(np.int32) for a in np.divmod(self.idx, w))
        row_base, col_base = (rows + 1) * (w + 1), cols.astype(np.intp) + (w + 1)
        line_cols, line_rows = np.arange(w, dtype=np.int32), np.arange(h, dtype=np.int32)[:, None]
        for i, (axis, line, here, size, after) in enumerate(((1, line_cols, cols, w, False), (1, line_cols, cols, w, True),
                                                             (0, line_rows, rows, h, False), (0, line_rows, rows, h, True))):
            # The nearest measured column / row at or before / after each pixel; none: a
            # sentinel at least ``far`` away.
            nearest = np.where(self.known, line, np.int32(2 * far if after else -far))
            run = nearest[(slice(None),) * axis + (slice(None, None, -1),)] if after else nearest
            (np.minimum if after else np.maximum).accumulate(run, axis=axis, out=run)
            nearest = self.at(nearest)
            gap = np.subtract(nearest, here) if after else np.subtract(here, nearest)
            out[i] = np.minimum(gap, far, out=gap)
            np.clip(nearest, -1, size, out=nearest)
            flat = np.add(row_base, nearest, dtype=np.intp) if axis == 1 else np.multiply(nearest, w + 1, dtype=np.intp)
            if axis == 0:
                flat += col_base
            np.take(padded, flat, out=out[4 + i])
