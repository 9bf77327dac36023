"""Occlusion protocols: named, versioned ways of drawing the holes a method must fill.

A mask is reproducible from ``(protocol, seed, frame index)`` alone::

    >>> from inpaintenv.masks import get_protocol
    >>> hole = get_protocol("rect-v1").mask((352, 1216), seed=0, index=7)
"""

from __future__ import annotations

from .base import OcclusionProtocol, mask_rng
from .densify import DensifyV1
from .ego import EgoOcclusionV1
from .freeform import FreeformV1
from .lidar import LidarDropoutV1
from .mixed import MixedV1
from .rect import RectV1
from ..exceptions import InvalidInputError, UnknownNameError

__all__ = [
    "DensifyV1",
    "EgoOcclusionV1",
    "FreeformV1",
    "LidarDropoutV1",
    "MixedV1",
    "OcclusionProtocol",
    "RectV1",
    "available_protocols",
    "get_protocol",
    "mask_rng",
    "register_protocol",
]

_REGISTRY: dict[str, type[OcclusionProtocol]] = {}


def register_protocol(cls: type[OcclusionProtocol]) -> type[OcclusionProtocol]:
    """Register a protocol class under its ``name`` (usable as a decorator)."""
    if not cls.name:
        raise InvalidInputError(f"{cls.__name__} has no name")
    if cls.name in _REGISTRY and _REGISTRY[cls.name] is not cls:
        raise InvalidInputError(f"protocol {cls.name!r} is already registered")
    _REGISTRY[cls.name] = cls
    return cls


def available_protocols() -> list[str]:
    """Names of the registered protocols, sorted."""
    return sorted(_REGISTRY)


def get_protocol(protocol: str | OcclusionProtocol) -> OcclusionProtocol:
    """Return a protocol instance by name (instances pass through).

    Raises
    ------
    KeyError
        If the name is unknown; the message lists the known ones.
    """
    if isinstance(protocol, OcclusionProtocol):
        return protocol
    try:
        return _REGISTRY[protocol]()
    except KeyError:
        raise UnknownNameError(
            f"unknown occlusion protocol {protocol!r}; available: {', '.join(available_protocols())}"
        ) from None


for _cls in (RectV1, LidarDropoutV1, EgoOcclusionV1, FreeformV1, MixedV1, DensifyV1):
    register_protocol(_cls)
