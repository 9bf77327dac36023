"""The pixels of a frame that lie far from any measurement: where a gated blend runs.

On a single LiDAR scan most unmeasured pixels lie a few pixels from a measurement, between
two scan lines, where a classical fill is hard to beat; a hole cut into the scan, or a
large gap, leaves pixels tens of pixels from the nearest one, where a learned blend of
several fills is far better (docs/model_cards/kitti-scan-v1.md).
"""

from __future__ import annotations

import cv2
import numpy as np

__all__ = ["far_pixels", "measured_rows"]


def measured_rows(measured: np.ndarray) -> np.ndarray:
    """``(H, W)`` bool: the rows from the first to the last that holds a measurement.

    The rows a sensor reaches: above them (sky) no beam returns and no truth scores a fill.
    """
    rows = np.flatnonzero(measured.any(axis=1))
    span = np.zeros(measured.shape, bool)
    if len(rows):
        span[rows[0] : rows[-1] + 1] = True
    return span


def far_pixels(x: np.ndarray, distance: float) -> np.ndarray:
    """Unmeasured pixels of ``x`` more than ``distance`` pixels from the nearest measurement.

    Parameters
    ----------
    x : numpy.ndarray
        ``(H, W)`` metres; NaN (to fill) or 0 = unmeasured.
    distance : float
        Euclidean distance in pixels (OpenCV's 5x5 distance transform, within 1 % of exact).

    Returns
    -------
    numpy.ndarray
        ``(H, W)`` bool, only within the rows the measurements span (:func:`measured_rows`);
        all False for a frame without any measurement.
    """
    measured = np.nan_to_num(np.asarray(x, np.float32), nan=0.0) > 0
    if not measured.any():
        return np.zeros(measured.shape, bool)
    gap = cv2.distanceTransform((~measured).astype(np.uint8), cv2.DIST_L2, 5)
    return (gap > float(distance)) & measured_rows(measured)
