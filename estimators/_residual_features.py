"""The shared pieces of :func:`estimators.candidates.residual_features`, at the pixels asked for (no torch).

A sparse scan leaves ~95 % of a frame to fill, so each channel stays one whole-frame operation
and one gather; what these pieces save is repeated work and whole-frame copies. One distance
nearest fill serves the ``nearest`` channel and both window fills' empty windows (each computed
it again), one cumulative scan per direction gives the
gap lengths and endpoint depths (without the interpolation weights a row/column fill needs), and
each channel is gathered as soon as it is made instead of from a stack of whole frames. The
numbers are those of :func:`~estimators.classical.nearest.nearest_fill`,
:func:`~estimators.candidates.window_extreme`, :func:`~estimators.candidates.gap_distances` and
:func:`~estimators.candidates.endpoint_values` (``tests/estimators/test_residual_features.py``
recomputes every channel from its definition).
"""

from __future__ import annotations

import os
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any, Callable

import cv2
import numpy as np

from inpaintenv.exceptions import InvalidInputError

from .classical.nearest import nearest_fill

__all__ = ["AtPixels", "flat_pixels", "overlap"]


class _Inline:
    """An executor that runs each task as it is submitted, in the calling thread."""

    def __enter__(self) -> _Inline:
        return self

    def __exit__(self, *exc: object) -> None:
        return None

    def submit(self, task: Callable[[], Any]) -> Future:
        future: Future = Future()
        future.set_result(task())
        return future


def overlap(wanted: bool = True) -> ThreadPoolExecutor | _Inline:
    """One worker thread if ``wanted`` and a core is free (1-minute load average below the cores), else inline.

    A worker overlaps ``harmonic`` with the other channels, and half the network's chunks with
    the other half, on a machine with a core to spare (16/8-beam KITTI scans on 2 cores at load
    average 1.7-2.1: ``kitti-sparse-v1`` 2.8x ``harmonic``'s time with workers, 4.6x inline); on
    a busy one its GIL hand-offs cost more than it saves (load 4.7-5.6: ``predict`` 173-177 ms
    inline, 196-221 ms with the worker). The numbers are the same either way.
    """
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    busy = os.getloadavg()[0] if hasattr(os, "getloadavg") else 0.0
    return ThreadPoolExecutor(max_workers=1) if wanted and busy < cores else _Inline()


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

    def at(self, image: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """``image`` ``(H, W)`` at the pixels (into ``out``, of its dtype, if given)."""
        return np.take(image.ravel(), self.idx, out=out)

    def nearest(self) -> np.ndarray:
        """:func:`~estimators.classical.nearest.nearest_fill` at the pixels."""
        if self._nearest is None:
            self._nearest = self.at(nearest_fill(self.values, self.known))  # once for the three fills that read it
        return self._nearest

    def window(self, far: bool, size: int) -> np.ndarray:
        """:func:`~estimators.candidates.window_extreme` at the pixels."""
        if not self.known.any():
            return np.zeros(len(self.idx), np.float32)
        kernel = np.ones((size, size), np.uint8)
        if far:
            out = self.at(cv2.dilate(np.where(self.known, self.values, np.float32(0)), kernel))
            empty = out <= 0
        else:
            # OpenCV pads an erosion with the type's largest value: anything that high is empty.
            out = self.at(cv2.erode(np.where(self.known, self.values, np.float32(np.inf)), kernel))
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
        # Indices in the narrowest type that holds the sentinels: less memory to stream.
        index = np.int16 if max(h, w) + 2 * far < np.iinfo(np.int16).max else np.int32
        # Row and column of each pixel, gathered (an int64 division costs 3x more).
        rows = self.at(np.repeat(np.arange(h, dtype=index), w))
        cols = self.at(np.tile(np.arange(w, dtype=index), h))
        row_base, col_base = (rows.astype(np.intp) + 1) * (w + 1), cols.astype(np.intp) + (w + 1)
        line_cols, line_rows = np.arange(w, dtype=index), np.arange(h, dtype=index)[:, None]
        # Buffers reused by the four directions: fresh large arrays cost page faults.
        nearest_frame, nearest, gap = np.empty((h, w), index), np.empty_like(rows), np.empty_like(rows)
        flat = np.empty(len(rows), np.intp)
        for i, (axis, line, here, size, after) in enumerate(((1, line_cols, cols, w, False), (1, line_cols, cols, w, True),
                                                             (0, line_rows, rows, h, False), (0, line_rows, rows, h, True))):
            # The nearest measured column / row at or before / after each pixel; none: a
            # sentinel at least ``far`` away.
            nearest_frame.fill(size + far if after else -far)
            np.copyto(nearest_frame, line, where=self.known)
            run = nearest_frame[(slice(None),) * axis + (slice(None, None, -1),)] if after else nearest_frame
            (np.minimum if after else np.maximum).accumulate(run, axis=axis, out=run)
            np.take(nearest_frame.ravel(), self.idx, out=nearest)
            np.subtract(nearest, here, out=gap) if after else np.subtract(here, nearest, out=gap)
            out[i] = np.minimum(gap, far, out=gap)
            np.clip(nearest, -1, size, out=nearest)
            if axis == 1:
                np.add(row_base, nearest, out=flat)
            else:
                np.multiply(nearest, w + 1, out=flat, dtype=np.intp)
                flat += col_base
            np.take(padded, flat, out=out[4 + i])
