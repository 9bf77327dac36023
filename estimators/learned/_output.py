"""What a learned inpainter returns in the pixels it fills: a positive depth, or 0 with nothing to fill from.

A network's raw output can be 0 m or negative in a hole (a U-Net trained for a few steps
often is); ``predict`` clips it at 0 m, and 0 m in a hole is what the benchmark, the env
and ``score`` read as *unfilled* (refused by default). A learned method always estimates,
so its hole pixels are floored at :data:`MIN_HOLE_DEPTH`. A frame without a single measured
pixel gives nothing to fill from: it is returned as 0 m everywhere (unfilled), as every
classical method returns it.
"""

from __future__ import annotations

import numpy as np

__all__ = ["MIN_HOLE_DEPTH", "floor_holes"]

#: Smallest depth a learned method returns in a hole pixel (metres): one step of KITTI's
#: 16-bit PNG (1/256 m), so the fill stays positive once written as a PNG, and above the
#: 1 mm below which inputs are refused (``inpaintenv.conventions.MIN_DEPTH``).
MIN_HOLE_DEPTH: float = 1.0 / 256.0


def floor_holes(pred: np.ndarray, X: np.ndarray) -> np.ndarray:
    """``pred`` with every hole pixel (NaN in the ``(N, H, W)`` input ``X``) at least
    :data:`MIN_HOLE_DEPTH`, and 0 everywhere in a frame without a measured pixel.

    Other pixels, and hole pixels already above the floor, keep their bits; NaN stays NaN
    (``predict`` refuses it).
    """
    floored = np.where(np.isnan(X), np.maximum(pred, MIN_HOLE_DEPTH), pred)  # maximum keeps NaN
    measured = (X > 0).any(axis=(-2, -1), keepdims=True)
    return np.where(measured, floored, 0.0).astype(np.float32, copy=False)
