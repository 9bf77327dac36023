"""Nearest-valid fill and the constant (median) sanity baseline."""

from __future__ import annotations

import cv2
import numpy as np

from ._base import ClassicalInpainter, unknown_mask

__all__ = ["ConstantInpainter", "NearestInpainter", "nearest_fill"]


def nearest_fill(values: np.ndarray, known: np.ndarray) -> np.ndarray:
    """Give every pixel the value of its nearest known pixel (Euclidean, 5×5 mask).

    Parameters
    ----------
    values : numpy.ndarray
        ``(H, W)`` values; only read where ``known``.
    known : numpy.ndarray
        ``(H, W)`` bool.

    Returns
    -------
    numpy.ndarray
        float32 ``(H, W)``; all zeros when nothing is known.
    """
    out = np.zeros(values.shape, dtype=np.float32)
    if not known.any():
        return out
    if known.all():
        return values.astype(np.float32, copy=True)
    # Labels of DIST_LABEL_PIXEL number the zero (= known) pixels 1..K in raster
    # order, the same order as values[known].
    _, labels = cv2.distanceTransformWithLabels(
        (~known).astype(np.uint8), cv2.DIST_L2, 5, labelType=cv2.DIST_LABEL_PIXEL
    )
    return values[known].astype(np.float32)[labels - 1]


class NearestInpainter(ClassicalInpainter):
    """Fill every unmeasured pixel with the depth of the nearest measured pixel.

    Parameters
    ----------
    keep_observed : bool, default=True
        Return measured input pixels unchanged.
    n_jobs : int or None, default=None
        Frames processed in parallel (joblib; None = 1, -1 = all cores).
    """

    def __init__(self, *, keep_observed: bool = True, n_jobs: int | None = None):
        self.keep_observed = keep_observed
        self.n_jobs = n_jobs

    def _fill_frame(self, x: np.ndarray) -> np.ndarray:
        return nearest_fill(x, ~unknown_mask(x))


class ConstantInpainter(ClassicalInpainter):
    """Fill every unmeasured pixel with the median measured depth of the frame.

    A sanity baseline: any method worth using must beat it. A frame without any
    measurement is filled with 0.

    Parameters
    ----------
    keep_observed : bool, default=True
        Return measured input pixels unchanged.
    n_jobs : int or None, default=None
        Frames processed in parallel (joblib; None = 1, -1 = all cores).
    """

    def __init__(self, *, keep_observed: bool = True, n_jobs: int | None = None):
        self.keep_observed = keep_observed
        self.n_jobs = n_jobs

    def _fill_frame(self, x: np.ndarray) -> np.ndarray:
        known = x > 0
        value = float(np.median(x[known])) if known.any() else 0.0
        return np.where(known, x, np.float32(value)).astype(np.float32)
