"""``rect-v1``: the study's protocol of 1-3 random axis-aligned rectangles."""

from __future__ import annotations

import math

import numpy as np

from .base import OcclusionProtocol

__all__ = ["RectV1"]


class RectV1(OcclusionProtocol):
    """1 to 3 axis-aligned rectangles per frame, each covering 5-20 % of the image.

    Per frame: the number of rectangles is uniform on {1, 2, 3}. Per rectangle: the area
    fraction ``a`` is uniform on [0.05, 0.20]; the shape relative to the image is
    ``s = exp(U(log 1/2, log 2))`` (log-uniform), so the rectangle is
    ``h = H·sqrt(a/s)`` by ``w = W·sqrt(a·s)`` -- on a 352×1216 KITTI crop that is a
    width/height ratio between 1.7 and 6.9 (the image's own is 3.5). Sizes are rounded to
    whole pixels while keeping the area fraction in [0.05, 0.20]; the position is uniform
    with the rectangle fully inside the image. Rectangles may overlap (as in the study),
    so the union covers 5 % to about 50 % of the frame.

    Parameters
    ----------
    min_rects, max_rects : int
    min_area, max_area : float
        Area fraction bounds of each rectangle.
    max_relative_aspect : float
        ``s`` is drawn log-uniformly from ``[1/max_relative_aspect, max_relative_aspect]``.
    """

    name = "rect-v1"
    description = "1-3 axis-aligned rectangles, each 5-20% of the image (the study's protocol)"

    def __init__(
        self,
        min_rects: int = 1,
        max_rects: int = 3,
        min_area: float = 0.05,
        max_area: float = 0.20,
        max_relative_aspect: float = 2.0,
    ):
        if not 1 <= min_rects <= max_rects:
            raise ValueError("need 1 <= min_rects <= max_rects")
        if not 0 < min_area <= max_area <= 1:
            raise ValueError("need 0 < min_area <= max_area <= 1")
        self.min_rects, self.max_rects = min_rects, max_rects
        self.min_area, self.max_area = min_area, max_area
        self.max_relative_aspect = max_relative_aspect

    def rectangles(self, shape: tuple[int, int], rng: np.random.Generator) -> list[tuple[int, int, int, int]]:
        """Draw the rectangles as ``(top, left, height, width)`` tuples."""
        H, W = shape
        total = H * W
        n = int(rng.integers(self.min_rects, self.max_rects + 1))
        rects = []
        log_s = math.log(self.max_relative_aspect)
        for _ in range(n):
            a = rng.uniform(self.min_area, self.max_area)
            s = math.exp(rng.uniform(-log_s, log_s))
            h = int(np.clip(round(H * math.sqrt(a / s)), 1, H))
            # Width from the rounded height keeps the area fraction in bounds.
            w_lo = math.ceil(self.min_area * total / h)
            w_hi = math.floor(self.max_area * total / h)
            w = int(np.clip(round(a * total / h), w_lo, min(w_hi, W)))
            w = max(1, min(w, W))
            top = int(rng.integers(0, H - h + 1))
            left = int(rng.integers(0, W - w + 1))
            rects.append((top, left, h, w))
        return rects

    def sample(self, shape: tuple[int, int], rng: np.random.Generator) -> np.ndarray:
        mask = np.zeros(shape, dtype=bool)
        for top, left, h, w in self.rectangles(shape, rng):
            mask[top : top + h, left : left + w] = True
        return mask
