"""``rect-v1``: the study's protocol of 1-3 random axis-aligned rectangles."""

from __future__ import annotations

import math

import numpy as np

from ..conventions import is_real_number
from .base import OcclusionProtocol, _check_rng, _check_shape
from ..exceptions import InvalidInputError, InvalidTypeError

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
    so the union covers 5 % to at most 60 % (3 × 20 %) of the frame, mean about 23 %.

    On small images the rounded height is moved to the nearest height for which a whole
    number of columns gives a 5-20 % area (this never happens at KITTI sizes, where the
    draws are exactly the study's); if no rectangle of 5-20 % fits at all (e.g. 2×2),
    :meth:`rectangles` raises ``ValueError``.

    Parameters
    ----------
    min_rects, max_rects : int
        Bounds (inclusive) of the number of rectangles per frame.
    min_area, max_area : float
        Area fraction bounds of each rectangle, ``0 < min_area <= max_area <= 1``.
    max_relative_aspect : float
        ``s`` is drawn log-uniformly from ``[1/max_relative_aspect, max_relative_aspect]``;
        must be finite and >= 1.
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
        if not (isinstance(min_rects, (int, np.integer)) and isinstance(max_rects, (int, np.integer))):
            raise InvalidTypeError("min_rects and max_rects must be integers")
        if not 1 <= min_rects <= max_rects:
            raise InvalidInputError(f"need 1 <= min_rects <= max_rects, got {min_rects}, {max_rects}")
        for key, value in (("min_area", min_area), ("max_area", max_area),
                           ("max_relative_aspect", max_relative_aspect)):
            if not is_real_number(value):
                raise InvalidTypeError(f"{key} must be a number, got {value!r}")
        if not 0 < min_area <= max_area <= 1:
            raise InvalidInputError(f"need 0 < min_area <= max_area <= 1, got {min_area}, {max_area}")
        # inf would pass ">= 1" and overflow when the log-uniform shape is drawn.
        if not (max_relative_aspect >= 1 and math.isfinite(max_relative_aspect)):
            raise InvalidInputError(f"max_relative_aspect must be a finite number >= 1, got {max_relative_aspect}")
        self.min_rects, self.max_rects = int(min_rects), int(max_rects)
        self.min_area, self.max_area = float(min_area), float(max_area)
        self.max_relative_aspect = float(max_relative_aspect)

    def hole_fraction_range(self) -> tuple[float, float]:
        """Union bounds: one rectangle of ``min_area`` up to ``max_rects`` disjoint ones of ``max_area``."""
        return self.min_area, min(1.0, round(self.max_rects * self.max_area, 6))

    def _width_bounds(self, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
        """For each height ``h = 1..H``, the smallest and largest width giving a valid area."""
        H, W = shape
        total = H * W
        hs = np.arange(1, H + 1)
        w_lo = np.maximum(np.ceil(self.min_area * total / hs), 1).astype(np.int64)
        w_hi = np.minimum(np.floor(self.max_area * total / hs), W).astype(np.int64)
        return w_lo, w_hi

    def rectangles(
        self, shape: tuple[int, int], rng: np.random.Generator
    ) -> list[tuple[int, int, int, int]]:
        """Draw the rectangles as ``(top, left, height, width)`` tuples.

        Raises
        ------
        ValueError
            If the shape is invalid or no rectangle covering ``min_area``-``max_area`` of
            the image fits in it.
        """
        H, W = _check_shape(shape)
        _check_rng(rng)
        total = H * W
        w_lo, w_hi = self._width_bounds((H, W))
        feasible = np.flatnonzero(w_lo <= w_hi) + 1  # heights with a valid whole width
        if feasible.size == 0:
            raise InvalidInputError(
                f"image {H}x{W} is too small for {self.name}: no rectangle covering "
                f"{self.min_area:.0%}-{self.max_area:.0%} of its {total} pixels fits"
            )
        n = int(rng.integers(self.min_rects, self.max_rects + 1))
        rects = []
        log_s = math.log(self.max_relative_aspect)
        for _ in range(n):
            a = rng.uniform(self.min_area, self.max_area)
            s = math.exp(rng.uniform(-log_s, log_s))
            # Scalar clipping with min/max: np.clip on Python numbers costs ~10 us a call.
            h = min(max(round(H * math.sqrt(a / s)), 1), H)
            if w_lo[h - 1] > w_hi[h - 1]:
                # Only on tiny images: take the nearest height that admits a valid width.
                h = int(feasible[np.argmin(np.abs(feasible - h))])
            # Width from the rounded height keeps the area fraction in bounds.
            w = int(min(max(round(a * total / h), w_lo[h - 1]), w_hi[h - 1]))
            top = int(rng.integers(0, H - h + 1))
            left = int(rng.integers(0, W - w + 1))
            rects.append((top, left, h, w))
        return rects

    def sample(self, shape: tuple[int, int], rng: np.random.Generator) -> np.ndarray:
        shape = _check_shape(shape)
        mask = np.zeros(shape, dtype=bool)
        for top, left, h, w in self.rectangles(shape, rng):
            mask[top : top + h, left : left + w] = True
        return mask
