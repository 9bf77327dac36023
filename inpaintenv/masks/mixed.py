"""``mixed-v1``: each mask drawn from one of the other protocols, chosen at random."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .base import OcclusionProtocol
from .ego import EgoOcclusionV1
from .freeform import FreeformV1
from .lidar import LidarDropoutV1
from .rect import RectV1
from ..exceptions import InvalidInputError

__all__ = ["MixedV1"]

_COMPONENTS: dict[str, type[OcclusionProtocol]] = {
    cls.name: cls for cls in (RectV1, LidarDropoutV1, EgoOcclusionV1, FreeformV1)
}


class MixedV1(OcclusionProtocol):
    """A uniform mixture of ``rect-v1``, ``lidar-dropout-v1``, ``ego-occlusion-v1``, ``freeform-v1``.

    Each mask first draws which protocol to use (uniformly, from the same generator),
    then draws that protocol's mask. Meant for training a model that should work
    under every protocol of the benchmark rather than one; a benchmark run should
    still report the protocols one by one.

    Parameters
    ----------
    components : sequence of str
        Names of the protocols to mix (default: all four above), each with its default
        parameters.
    """

    name = "mixed-v1"
    MIN_SHAPE = (32, 32)  # with the default components; an instance recomputes it for its own
    description = "each frame's mask drawn from rect-v1, lidar-dropout-v1, ego-occlusion-v1 or freeform-v1 (uniform)"

    def __init__(self, components: Sequence[str] = tuple(_COMPONENTS)):
        if isinstance(components, str) or not components:
            raise InvalidInputError(f"components must be a non-empty sequence of protocol names, got {components!r}")
        unknown = [c for c in components if c not in _COMPONENTS]
        if unknown:
            raise InvalidInputError(f"unknown components {unknown}; choose from {sorted(_COMPONENTS)}")
        self.components = tuple(components)
        self._protocols = [_COMPONENTS[c]() for c in self.components]
        # The largest minimum over the components: every one must be able to draw.
        self.MIN_SHAPE = tuple(int(max(p.MIN_SHAPE[i] for p in self._protocols)) for i in range(2))

    def hole_fraction_range(self) -> tuple[float, float] | None:
        ranges = [p.hole_fraction_range() for p in self._protocols]
        if any(r is None for r in ranges):
            return None
        return min(r[0] for r in ranges), max(r[1] for r in ranges)

    def sample(self, shape: tuple[int, int], rng: np.random.Generator) -> np.ndarray:
        shape = self._check_args(shape, rng)
        return self._protocols[int(rng.integers(len(self._protocols)))].sample(shape, rng)
