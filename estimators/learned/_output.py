"""What a learned inpainter returns: a depth inside the range it was trained for, or 0 with nothing to fill from.

Every learned prediction passes :func:`bound_output`, the one place learned outputs are made:

- a network's raw output can be 0 m or negative in a hole (a U-Net trained for a few steps
  often is); ``predict`` clips it at 0 m, and 0 m in a hole is what the benchmark, the env
  and ``score`` read as *unfilled* (refused by default). A learned method always estimates,
  so its hole pixels are floored at :data:`MIN_HOLE_DEPTH`;
- it can also be far beyond any depth it was trained on (a briefly trained U-Net predicts
  300 m), which the benchmark, ``fill`` and the env refuse as no depth at all. No training
  frame holds more than :data:`~inpaintenv.conventions.DEPTH_LIMIT` (inputs above it are
  refused), so every pixel is capped at :data:`MAX_OUTPUT_DEPTH`, that bound;
- a frame without a single measured pixel gives nothing to fill from: it is returned as
  0 m everywhere (unfilled), as every classical method returns it.
"""

from __future__ import annotations

import numpy as np

from inpaintenv.conventions import DEPTH_LIMIT

__all__ = ["MAX_OUTPUT_DEPTH", "MIN_HOLE_DEPTH", "bound_output"]

#: Smallest depth a learned method returns in a hole pixel (metres): one step of KITTI's
#: 16-bit PNG (1/256 m), so the fill stays positive once written as a PNG, and above the
#: 1 mm below which inputs are refused (``inpaintenv.conventions.MIN_DEPTH``).
MIN_HOLE_DEPTH: float = 1.0 / 256.0
#: Largest depth a learned method returns (metres): the most any training frame can hold
#: (:data:`~inpaintenv.conventions.DEPTH_LIMIT`, 255.996 m, the bound of a KITTI PNG and of
#: the environment's action space).
MAX_OUTPUT_DEPTH: float = DEPTH_LIMIT


def bound_output(pred: np.ndarray, X: np.ndarray) -> np.ndarray:
    """``pred`` inside the range a learned model was trained for.

    Every pixel at most :data:`MAX_OUTPUT_DEPTH`; every hole pixel (NaN in the
    ``(N, H, W)`` input ``X``) at least :data:`MIN_HOLE_DEPTH`; 0 everywhere in a frame
    without a measured pixel. Pixels already inside keep their bits; NaN stays NaN
    (``predict`` refuses it).
    """
    capped = np.minimum(pred, np.float32(MAX_OUTPUT_DEPTH))  # minimum keeps NaN
    floored = np.where(np.isnan(X), np.maximum(capped, MIN_HOLE_DEPTH), capped)
    measured = (X > 0).any(axis=(-2, -1), keepdims=True)
    return np.where(measured, floored, 0.0).astype(np.float32, copy=False)
