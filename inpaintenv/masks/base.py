"""The occlusion-protocol interface and its reproducible seeding."""

from __future__ import annotations

import inspect
import operator
import zlib
from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..conventions import check_seed, check_seeds
from ..exceptions import InvalidInputError, InvalidTypeError

__all__ = ["OcclusionProtocol", "mask_rng"]


def mask_rng(name: str, seed: int, index: int) -> np.random.Generator:
    """The generator that draws the mask of frame ``index`` under ``(protocol, seed)``.

    Seeding from the triple alone (not from a running stream) makes each mask
    reproducible on its own, in any order, in any process.

    Raises
    ------
    TypeError
        If ``seed`` or ``index`` is not an integer (a float or bool is not truncated).
    ValueError
        If either is negative.
    """
    seed, index = check_seed(seed, "seed"), check_seed(index, "index")
    return np.random.default_rng(np.random.SeedSequence([zlib.crc32(name.encode()), seed, index]))


class OcclusionProtocol(ABC):
    """A named, versioned way of drawing occlusion masks.

    Subclasses set ``name`` (e.g. ``"rect-v1"``; a change of behaviour gets a new
    version, never an edit of an old one) and implement :meth:`sample`.
    """

    name: str = ""
    description: str = ""
    #: The pixels a task under the protocol is scored on, and its headline metric
    #: ``{task}_rmse``: ``"hole"``, or ``"unmeasured"`` (every pixel the input lacks) for
    #: a protocol that cuts no hole (``densify-v1``).
    task: str = "hole"

    @abstractmethod
    def sample(self, shape: tuple[int, int], rng: np.random.Generator) -> np.ndarray:
        """Draw one mask.

        Parameters
        ----------
        shape : (int, int)
            ``(H, W)`` of the frame.
        rng : numpy.random.Generator
            The only source of randomness.

        Returns
        -------
        numpy.ndarray
            ``(H, W)`` bool, True inside the occlusion.
        """

    #: Smallest ``(H, W)`` the protocol can draw on (checked by :meth:`_check_args`).
    MIN_SHAPE: tuple[int, int] = (1, 1)

    def _check_args(self, shape: tuple[int, int], rng: np.random.Generator) -> tuple[int, int]:
        """Validate ``sample``'s arguments; return ``(H, W)``."""
        H, W = _check_shape(shape)
        _check_rng(rng)
        if H < self.MIN_SHAPE[0] or W < self.MIN_SHAPE[1]:
            raise InvalidInputError(
                f"{self.name} needs frames of at least {self.MIN_SHAPE[0]}x{self.MIN_SHAPE[1]} "
                f"(H x W), got {H}x{W}"
            )
        return H, W

    def mask(self, shape: tuple[int, int], seed: int, index: int) -> np.ndarray:
        """The reproducible mask of frame ``index`` for evaluation ``seed``.

        ``seed`` and ``index`` are non-negative integers (see :func:`mask_rng`).
        """
        shape = _check_shape(shape)
        return self.sample(shape, mask_rng(self.name, seed, index))

    def masks(self, shape: tuple[int, int], seed: int, indices: Sequence[int]) -> np.ndarray:
        """Masks of several frames as one ``(N, H, W)`` bool array.

        ``indices`` are non-negative integers (repeats allowed); floats are refused,
        never truncated to another frame's mask.
        """
        shape = _check_shape(shape)
        seed = check_seed(seed, "seed")
        idx = check_seeds(indices, "indices", distinct=False, allow_empty=True)
        out = np.empty((len(idx), *shape), dtype=bool)
        for k, i in enumerate(idx):
            out[k] = self.mask(shape, seed, i)
        return out

    def get_params(self) -> dict[str, Any]:
        """Constructor parameters and their current values (scikit-learn style).

        Subclasses store each ``__init__`` argument as an attribute of the same name.
        """
        sig = inspect.signature(type(self).__init__)
        return {
            k: _plain(getattr(self, k))
            for k, p in sig.parameters.items()
            if k != "self" and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)
        }

    def hole_fraction_range(self) -> tuple[float, float] | None:
        """Documented bounds of the fraction of the frame a mask covers (None if unknown)."""
        return None

    def describe(self) -> dict[str, Any]:
        """JSON-serialisable record of the protocol for reports and ``results.json``.

        Returns
        -------
        dict
            ``name``, ``description``, ``class``, ``params`` (see :meth:`get_params`),
            ``constants`` (the class's upper-case attributes: the fixed parameters of
            the protocol's distributions) and ``hole_fraction_range`` (``[low, high]``
            or None).
        """
        rng = self.hole_fraction_range()
        constants = {}
        for klass in reversed(type(self).__mro__):
            constants.update({k: _plain(v) for k, v in vars(klass).items() if k.isupper()})
        return {
            "name": self.name,
            "description": self.description,
            "class": f"{type(self).__module__}.{type(self).__qualname__}",
            "params": self.get_params(),
            "constants": constants,
            "hole_fraction_range": None if rng is None else [float(rng[0]), float(rng[1])],
        }

    def __repr__(self) -> str:
        return f"{type(self).__name__}(name={self.name!r})"


def _plain(value: Any) -> Any:
    """NumPy scalars and tuples as plain Python values, so ``describe()`` dumps to JSON."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, (tuple, list)):
        return [_plain(v) for v in value]
    return value


def _check_shape(shape: tuple[int, int]) -> tuple[int, int]:
    """``(H, W)`` as two Python ints >= 1, or a ValueError naming the bad shape."""
    try:
        dims = [operator.index(d) for d in shape]  # ints only: 3.5 rows is an error
    except TypeError:
        raise InvalidInputError(f"mask shape must be (H, W) with integer H, W >= 1, got {shape!r}") from None
    if len(dims) != 2 or min(dims) < 1:
        raise InvalidInputError(f"mask shape must be (H, W) with H, W >= 1, got {shape!r}")
    return dims[0], dims[1]


def _check_rng(rng: object) -> np.random.Generator:
    """Protocols draw only from a ``numpy.random.Generator``; refuse anything else clearly."""
    if not isinstance(rng, np.random.Generator):
        raise InvalidTypeError(
            f"rng must be a numpy.random.Generator (e.g. mask_rng(name, seed, index)), "
            f"got {type(rng).__name__}"
        )
    return rng
