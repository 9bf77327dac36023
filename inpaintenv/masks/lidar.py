"""``lidar-dropout-v1``: what a spinning LiDAR really loses, projected into the image."""

from __future__ import annotations

import math

import numpy as np

from ._raster import smooth_noise
from .base import OcclusionProtocol

__all__ = ["LidarDropoutV1"]


class LidarDropoutV1(OcclusionProtocol):
    """Missing beams, missing azimuth sectors and reflective/absorbing patches.

    Three independent components, drawn in this order from the frame's generator
    (``U`` uniform, ``U{a..b}`` uniform on integers):

    * **Missing beams** (always). A LiDAR beam sweeps one elevation angle, which the
      camera sees as a thin near-horizontal curve. ``k ~ U{2..8}`` bands; the beam
      budget ``f_b ~ U(0.05, 0.20)`` of the frame is shared equally, so every band is
      ``t = ceil(f_b·H/k)`` rows thick. The image height is cut into ``k`` equal
      strata and band ``i`` lies inside stratum ``i`` (bands never overlap, so this
      component covers exactly ``k·t/H >= f_b``). Each band bends as
      ``a·u²`` with ``u = (x - W/2)/(W/2)`` and sag ``a ~ U(-1, 1)·0.02·H`` (sign =
      bending up or down at the image edges), with its top row uniform among the
      positions that keep it inside its stratum.
    * **Missing azimuth sectors** (with probability 0.5). The scanner loses a range
      of azimuths (blocked window, dropped packets): ``n_s ~ U{1..2}`` full-height
      column bands sharing a budget ``f_s ~ U(0.03, 0.12)`` of the width equally,
      each at a uniform column; they may overlap each other and the beams.
    * **Reflective / absorbing patches** (with probability 0.7). Surfaces that return
      nothing (black paint, glass, wet road): smooth Gaussian noise with correlation
      length ``c ~ U(0.08, 0.20)·H`` pixels, drawn at half resolution (2×2-pixel
      cells) and thresholded at its ``1 - f_p`` quantile (estimated on every 8th row
      and column of the frame), ``f_p ~ U(0.02, 0.15)``.

    The hole fraction is therefore at least ``f_b >= 0.05`` (beams alone) and at most
    the sum of the budgets, ``0.20 + 0.12 + 0.15`` plus rounding (``<= 0.50`` at
    KITTI sizes): :meth:`hole_fraction_range` returns ``(0.05, 0.50)``. On small frames
    rounding bands and sectors up to whole pixels inflates them (see
    ``docs/protocols.md``: maximum 0.70 over 1000 masks at 32×16); the lower bound
    always holds.

    Requires ``H >= 32`` and ``W >= 16`` (smaller frames cannot hold 8 separate
    bands with room to bend); smaller shapes raise ``ValueError``.
    """

    name = "lidar-dropout-v1"
    description = (
        "LiDAR dropout: 2-8 missing beam bands (5-20% of rows), optional missing azimuth "
        "sectors (3-12% of columns), optional reflective/absorbing noise patches (2-15%)"
    )

    MIN_SHAPE = (32, 16)
    BANDS = (2, 8)
    BEAM_FRACTION = (0.05, 0.20)
    BEAM_SAG = 0.02
    SECTOR_PROB = 0.5
    SECTORS = (1, 2)
    SECTOR_FRACTION = (0.03, 0.12)
    PATCH_PROB = 0.7
    PATCH_FRACTION = (0.02, 0.15)
    PATCH_CELL = (0.08, 0.20)

    def hole_fraction_range(self) -> tuple[float, float]:
        """``(0.05, 0.50)``: beams alone reach 5 %; all budgets together stay under 50 %."""
        return 0.05, 0.50

    def sample(self, shape: tuple[int, int], rng: np.random.Generator) -> np.ndarray:
        H, W = self._check_args(shape, rng)
        mask = self._beams((H, W), rng)
        if rng.random() < self.SECTOR_PROB:
            n_s = int(rng.integers(self.SECTORS[0], self.SECTORS[1] + 1))
            f_s = rng.uniform(*self.SECTOR_FRACTION)
            width = max(1, round(f_s * W / n_s))
            for left in rng.integers(0, W - width + 1, size=n_s):
                mask[:, left : left + width] = True
        if rng.random() < self.PATCH_PROB:
            f_p = rng.uniform(*self.PATCH_FRACTION)
            cell = rng.uniform(*self.PATCH_CELL) * H
            # The field is smooth over >= 0.08·H pixels, so it is drawn at half
            # resolution and each cell covers 2×2 pixels: 4x cheaper, same blobs.
            field = smooth_noise(((H + 1) // 2, (W + 1) // 2), rng, cell / 2)
            patch = field > np.quantile(field[::4, ::4], 1.0 - f_p)
            mask |= np.repeat(np.repeat(patch, 2, axis=0), 2, axis=1)[:H, :W]
        return mask

    def _beams(self, shape: tuple[int, int], rng: np.random.Generator) -> np.ndarray:
        """Non-overlapping bent row bands, one per stratum of the height."""
        H, W = shape
        k = int(rng.integers(self.BANDS[0], self.BANDS[1] + 1))
        f_b = rng.uniform(*self.BEAM_FRACTION)
        t = math.ceil(f_b * H / k)
        sag = rng.uniform(-1.0, 1.0, size=k) * self.BEAM_SAG * H
        edges = np.floor(np.arange(k + 1) * H / k).astype(np.int64)
        # Room left in each stratum once the band and its sag are in (>= 0 for H >= 32).
        room = np.maximum(edges[1:] - edges[:-1] - t - np.ceil(np.abs(sag)), 0)
        top = edges[:-1] + np.floor(rng.random(k) * (room + 1))
        u2 = ((np.arange(W) - (W - 1) / 2) / ((W - 1) / 2 if W > 1 else 1.0)) ** 2
        # Downward sag (a > 0) bends the edges down; upward starts |a| lower so the
        # band stays within [top, top + t + |a|].
        offset = np.where(sag >= 0, 0.0, -sag)[:, None] + sag[:, None] * u2[None, :]
        first = (top[:, None] + np.rint(offset)).astype(np.int64)  # (k, W) first row of each band
        mask = np.zeros((H, W), dtype=bool)
        for i in range(k):  # only the few rows each band can reach
            y0, y1 = int(first[i].min()), int(first[i].max()) + t
            ys = np.arange(y0, y1)[:, None]
            mask[y0:y1] = (ys >= first[i]) & (ys < first[i] + t)
        return mask
