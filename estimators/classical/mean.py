"""The per-pixel mean of several classical fills.

Two fills that err in different ways average to a better one: on a single LiDAR scan,
``harmonic`` (smooth, overshoots at depth edges) and ``ipbasic-scan`` (morphological,
keeps the nearer surface) are each beaten by their mean on every set of the KITTI slice
(docs/baselines.md). Torch-free, unlike the learned ``MeanEnsembleInpainter``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from inpaintenv.methods.classical import CLASSICAL_METHODS
from inpaintenv.exceptions import InvalidInputError, InvalidTypeError

from .._constraints import Check
from ._base import ClassicalInpainter
from .bilateral import IterativeBilateralInpainter
from .harmonic import HarmonicInpainter
from .ipbasic import IPBasicInpainter
from .nearest import ConstantInpainter, NearestInpainter
from .opencv import NavierStokesInpainter, TeleaInpainter
from .scanline import ScanlineInpainter

__all__ = ["MeanInpainter"]

_CLASSES = {cls.__name__: cls for cls in (
    ConstantInpainter, HarmonicInpainter, IPBasicInpainter, IterativeBilateralInpainter, NavierStokesInpainter,
    NearestInpainter, ScanlineInpainter, TeleaInpainter)}
#: The single classical fills by registered name (a mean of means is not one).
_BY_NAME = {name: (cls, kwargs) for name, cls, kwargs, _ in CLASSICAL_METHODS if cls in _CLASSES}


def _classical(name: str) -> ClassicalInpainter:
    """The classical fill registered as ``name`` (inpaintenv.methods.classical)."""
    cls, kwargs = _BY_NAME[name]
    return _CLASSES[cls](**kwargs)


def _member(i: int, method: Any) -> ClassicalInpainter:
    """Item ``i`` of ``methods`` as a fill whose parameters are checked."""
    if isinstance(method, str):
        if method not in _BY_NAME:
            raise InvalidInputError(f"methods[{i}]: {method!r} is not a classical method; "
                                    f"known: {', '.join(sorted(_BY_NAME))}")
        return _classical(method)
    if not isinstance(method, ClassicalInpainter) or isinstance(method, MeanInpainter):
        raise InvalidTypeError(f"methods[{i}] must be a classical method's name or instance, got {method!r}")
    try:
        method._check_params()
    except (InvalidInputError, InvalidTypeError) as err:
        kind = InvalidTypeError if isinstance(err, TypeError) else InvalidInputError
        raise kind(f"methods[{i}] ({type(method).__name__}): {err}") from err
    return method


def _member_fills(methods: Any) -> list[ClassicalInpainter]:
    """The fills ``methods`` names (a :class:`MeanInpainter` parameter), checked.

    Raises
    ------
    InvalidInputError, InvalidTypeError
        One error naming ``methods`` (and the item at fault).
    """
    if isinstance(methods, (str, bytes)) or not isinstance(methods, Sequence) or len(methods) < 2:
        raise InvalidInputError(f"methods must list at least two classical fills, got {methods!r}")
    return [_member(i, m) for i, m in enumerate(methods)]


class MeanInpainter(ClassicalInpainter):
    """Fill every unmeasured pixel with the mean of several classical fills.

    Parameters
    ----------
    methods : sequence of str or ClassicalInpainter, default ("harmonic", "ipbasic-scan")
        At least two classical fills: registered names (``inpaintenv info`` lists them) or
        instances. Each fills the frame; the result is their per-pixel mean.
    keep_observed : bool, default=True
        Return measured input pixels unchanged.
    n_jobs : int or None, default=None
        Frames processed in parallel (joblib; None = 1, -1 = all cores).

    Examples
    --------
    >>> import numpy as np
    >>> from estimators.classical import MeanInpainter
    >>> x = np.full((16, 24), 10.0, np.float32); x[4:9, 5:12] = np.nan
    >>> float(MeanInpainter().predict(x)[6, 8])
    10.0
    """

    def __init__(self, *, methods: Sequence[Any] = ("harmonic", "ipbasic-scan"), keep_observed: bool = True,
                 n_jobs: int | None = None):
        self.methods = methods
        self.keep_observed = keep_observed
        self.n_jobs = n_jobs

    _parameter_constraints = {
        **ClassicalInpainter._parameter_constraints,
        "methods": [Check(_member_fills)],
    }

    def _fill_frame(self, x: np.ndarray) -> np.ndarray:
        fills = _member_fills(self.methods)
        total = np.zeros(x.shape, dtype=np.float64)
        for fill in fills:
            total += fill._fill_frame(x)
        return (total / len(fills)).astype(np.float32)
