"""OpenCV's image inpainting (Telea, Navier-Stokes) applied to float32 depth."""

from __future__ import annotations

import cv2
import numpy as np

from inpaintenv.conventions import MIN_DEPTH

from .._constraints import Integer, Options
from ._base import FILL_MODES, ClassicalInpainter, unknown_mask
from .nearest import nearest_fill

__all__ = ["NavierStokesInpainter", "TeleaInpainter"]

#: Frames narrower than this (in either direction) are padded before cv2.inpaint.
_MIN_SIDE = 3


class _OpenCVInpainter(ClassicalInpainter):
    """``cv2.inpaint`` on float32 depth; subclasses choose the algorithm flag."""

    _flag: int

    def __init__(
        self, *, radius: int = 5, fill: str = "invalid", keep_observed: bool = True,
        n_jobs: int | None = None,
    ):
        self.radius = radius
        self.fill = fill
        self.keep_observed = keep_observed
        self.n_jobs = n_jobs

    _parameter_constraints = {
        **ClassicalInpainter._parameter_constraints,
        "radius": [Integer(1)],
        "fill": [Options(*FILL_MODES)],
    }

    def _fill_frame(self, x: np.ndarray) -> np.ndarray:
        unknown = unknown_mask(x, self.fill)
        # Known pixels keep their value: a measurement, or 0 = depth 0 under fill="hole".
        src = np.where(unknown, 0.0, x).astype(np.float32)
        if not unknown.any() or unknown.all():
            return src
        mask = unknown.astype(np.uint8)
        if min(src.shape) >= _MIN_SIDE:
            out = cv2.inpaint(src, mask, float(self.radius), self._flag)
        else:
            # cv2.inpaint reads uninitialised memory on 1-pixel-high or -wide images (NaN or
            # garbage values, depending on the heap); a 1-pixel replicated border avoids it.
            padded = np.pad(src, 1, mode="edge")
            out = cv2.inpaint(padded, np.pad(mask, 1, mode="edge"), float(self.radius), self._flag)[1:-1, 1:-1]
        if self.fill == "invalid":
            # Far from sparse measurements cv2.inpaint oscillates and can go to 0 or below
            # (seen on KITTI: a hole pixel of drive 9009 at -0.4 m); every pixel to fill
            # gets a depth, so those below the smallest valid depth take the nearest
            # measurement's.
            left = unknown & ~(out >= MIN_DEPTH)
            if left.any():
                known = ~unknown
                out[left] = nearest_fill(np.where(known, x, 0.0).astype(np.float32), known)[left]
        return out


class TeleaInpainter(_OpenCVInpainter):
    """Telea's fast-marching inpainting (``cv2.INPAINT_TELEA``) on depth.

    Parameters
    ----------
    radius : int, default=5
        Neighbourhood radius in pixels considered for each filled pixel.
    fill : {"invalid", "hole"}, default="invalid"
        ``"invalid"``: every pixel without a measurement (NaN or 0) is unknown.
        ``"hole"``: only the NaN pixels are filled and unmeasured pixels (0) count as
        depth 0 -- what the study did; it drags the fill towards 0 on semi-dense LiDAR.
    keep_observed : bool, default=True
        Return measured input pixels unchanged.
    n_jobs : int or None, default=None
        Frames processed in parallel (joblib; None = 1, -1 = all cores).
    """

    _flag = cv2.INPAINT_TELEA


class NavierStokesInpainter(_OpenCVInpainter):
    """Navier-Stokes based inpainting (``cv2.INPAINT_NS``) on depth.

    Parameters
    ----------
    radius : int, default=5
        Neighbourhood radius in pixels considered for each filled pixel.
    fill : {"invalid", "hole"}, default="invalid"
        ``"invalid"``: every pixel without a measurement (NaN or 0) is unknown.
        ``"hole"``: only the NaN pixels are filled and unmeasured pixels (0) count as
        depth 0 (the study's behaviour).
    keep_observed : bool, default=True
        Return measured input pixels unchanged.
    n_jobs : int or None, default=None
        Frames processed in parallel (joblib; None = 1, -1 = all cores).
    """

    _flag = cv2.INPAINT_NS
