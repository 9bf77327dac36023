"""``ego-occlusion-v1``: the recording vehicle hiding part of its own view."""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from ._raster import fill_intervals
from .base import OcclusionProtocol
from ..exceptions import InvalidInputError

__all__ = ["EgoOcclusionV1"]

_PARTS = ("bonnet", "pole", "mirror")


class EgoOcclusionV1(OcclusionProtocol):
    """A fixed bonnet, roof-rack pole and mirror, with small per-frame jitter.

    The geometry is fixed by the protocol (a sensor rigidly mounted on one vehicle sees
    the same parts of that vehicle in every frame); each frame jitters it slightly, as
    vibration, suspension travel and calibration noise do. All lengths are fractions of
    the frame (``u = (x - x_c)/(W/2)``; ``U(a, b)`` uniform):

    * **bonnet** (hood) across the bottom: the pixels below the curve
      ``y(x) = H - h·(1 - c·u²) + r·u·H``, i.e. highest at the centre ``x_c`` and
      falling towards the sides. Nominal ``h = 0.16·H``, ``c = 0.55``, ``x_c = W/2``;
      jitter ``h × U(0.9, 1.1)``, ``c + U(-0.05, 0.05)``, ``x_c + U(-0.02, 0.02)·W``,
      roll ``r ~ U(-0.01, 0.01)``.
    * **pole** (roof-rack pole / A-pillar) on the right: a band from the top of the frame
      down to the bonnet, centre at ``0.93·W`` at the top, leaning inwards by
      ``0.06·W`` over the frame height, width ``0.035·W``; jitter: position
      ``U(-0.01, 0.01)·W``, lean ``U(-0.01, 0.01)·W``, width ``× U(0.9, 1.1)``.
    * **mirror** housing at the left edge: an ellipse centred at ``(0.78·H, 0.02·W)``
      with semi-axes ``(0.12·H, 0.07·W)``, half outside the frame; jitter: centre
      ``U(-0.02, 0.02)`` of ``H`` and ``W``, semi-axes ``× U(0.95, 1.05)``.

    With all three parts the hole covers about 18 % of the frame; by construction it
    stays within :meth:`hole_fraction_range` ``(0.10, 0.30)`` (checked by the tests and
    measured in ``docs/protocols.md``). With a subset of ``parts`` the range is ``(0, 0.30)``.

    Parameters
    ----------
    parts : iterable of {"bonnet", "pole", "mirror"}
        Which parts of the vehicle occlude the view (all three by default). The jitter
        draws are made for every part whether it is shown or not, so a part looks the
        same in a given frame whatever the other parts.
    """

    name = "ego-occlusion-v1"
    description = (
        "ego-vehicle self-occlusion: curved bonnet across the bottom, roof-rack pole on the "
        "right, mirror at the left edge; fixed geometry with small per-frame jitter"
    )

    MIN_SHAPE = (8, 8)

    def __init__(self, parts: Iterable[str] = _PARTS):
        if isinstance(parts, str):
            parts = (parts,)
        parts = tuple(parts)
        unknown = sorted(set(parts) - set(_PARTS))
        if unknown or not parts:
            raise InvalidInputError(
                f"parts must be a non-empty subset of {_PARTS}, got {parts!r}"
            )
        # Canonical order so that equal sets describe equally.
        self.parts = tuple(p for p in _PARTS if p in parts)

    def hole_fraction_range(self) -> tuple[float, float]:
        """``(0.10, 0.30)`` with the bonnet (it alone covers over 10 %), else ``(0, 0.30)``."""
        return (0.10 if "bonnet" in self.parts else 0.0), 0.30

    def sample(self, shape: tuple[int, int], rng: np.random.Generator) -> np.ndarray:
        H, W = self._check_args(shape, rng)
        # One fixed-size draw for all parts keeps each part's jitter independent of `parts`.
        j = rng.uniform(-1.0, 1.0, size=11)
        x = np.arange(W, dtype=np.float64)
        rows, los, his = [], [], []

        # Bonnet: per-column vertical runs from the curve to the bottom edge.
        h = 0.16 * H * (1 + 0.1 * j[0])
        c = 0.55 + 0.05 * j[1]
        xc = W / 2 + 0.02 * W * j[2]
        u = (x - xc) / (W / 2)
        bonnet_top = H - h * (1 - c * u**2) + 0.01 * j[3] * u * H
        # Pole: per-row horizontal runs; it ends where the bonnet starts.
        y = np.arange(H, dtype=np.float64)
        half_w = 0.035 * W * (1 + 0.1 * j[4]) / 2
        lean = (0.06 + 0.01 * j[5]) * W
        centre = (0.93 + 0.01 * j[6]) * W - lean * y / H
        # Mirror: ellipse, per-row horizontal runs.
        cy = (0.78 + 0.02 * j[7]) * H
        cx = (0.02 + 0.02 * j[8]) * W
        ay = 0.12 * H * (1 + 0.05 * j[9])
        ax = 0.07 * W * (1 + 0.05 * j[10])

        mask = np.zeros((H, W), dtype=bool)
        if "bonnet" in self.parts:
            # Everything below the curve: one broadcast comparison.
            mask |= y[:, None] >= np.ceil(bonnet_top)[None, :]
        if "pole" in self.parts:
            col = np.clip(np.rint(centre).astype(np.int64), 0, W - 1)
            # Stop at the bonnet only when it is drawn, so the pole alone reaches the bottom.
            below = y >= bonnet_top[col] if "bonnet" in self.parts else np.zeros(H, bool)
            rows.append(np.arange(H))
            los.append(np.where(below, 1.0, centre - half_w))
            his.append(np.where(below, 0.0, centre + half_w))
        if "mirror" in self.parts:
            dy = (y - cy) / ay
            inside = np.abs(dy) <= 1
            half = ax * np.sqrt(np.clip(1 - dy**2, 0, None))
            rows.append(np.arange(H))
            los.append(np.where(inside, cx - half, 1.0))
            his.append(np.where(inside, cx + half, 0.0))
        if rows:
            mask |= fill_intervals((H, W), np.concatenate(rows), np.concatenate(los), np.concatenate(his))
        return mask
