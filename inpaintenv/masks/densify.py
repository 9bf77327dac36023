"""``densify-v1``: no hole; the task is to fill every pixel the input did not measure."""

from __future__ import annotations

import numpy as np

from .base import OcclusionProtocol

__all__ = ["DensifyV1"]


class DensifyV1(OcclusionProtocol):
    """No hole at all (an all-False mask): fill every pixel the input did not measure.

    Meant for a single LiDAR scan as the input (``input="scan"``, see
    :mod:`inpaintenv.data.inputs`): the method is given the scan (about 5 % of the
    pixels) and is scored on the ground-truth pixels the scan did not measure (the
    ``unmeasured_*`` metrics; the ``hole_*`` ones are NaN with a count of 0). On a map
    input there is nothing to fill, so only the scan input gives it a task.

    The mask draws nothing from its generator, so it is the same for every seed and
    frame; it is still seeded like every protocol, so a run's masks are reproducible
    from ``(protocol, seed, index)`` whatever the protocol.
    """

    name = "densify-v1"
    task = "unmeasured"
    description = "no hole: fill every pixel the input (a single LiDAR scan) did not measure"

    def hole_fraction_range(self) -> tuple[float, float]:
        return 0.0, 0.0

    def sample(self, shape: tuple[int, int], rng: np.random.Generator) -> np.ndarray:
        shape = self._check_args(shape, rng)
        return np.zeros(shape, dtype=bool)
