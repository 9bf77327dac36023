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

    def _check_params(self) -> None:
        super()._check_params()
        self._fills()

    def _fills(self) -> list[ClassicalInpainter]:
        """The fills ``methods`` names, checked."""
        methods = self.methods
        if isinstance(methods, (str, bytes)) or not isinstance(methods, Sequence) or len(methods) < 2:
            raise InvalidInputError(f"MeanInpainter: methods must list at least two classical fills, got {methods!r}")
        fills = []
        for m in methods:
            if isinstance(m, str):
                if m not in _BY_NAME:
                    raise InvalidInputError(f"MeanInpainter: {m!r} is not a classical method; "
                                            f"known: {', '.join(sorted(_BY_NAME))}")
                fills.append(_classical(m))
            elif isinstance(m, ClassicalInpainter) and not isinstance(m, MeanInpainter):
                fills.append(m)
            else:
                raise InvalidTypeError(f"MeanInpainter: each method is a classical method's name or instance, "
                                       f"got {m!r}")
        for fill in fills:
            fill._check_params()
        return fills

    def _fill_frame(self, x: np.ndarray) -> np.ndarray:
        fills = self._fills()
        total = np.zeros(x.shape, dtype=np.float64)
        for fill in fills:
            total += fill._fill_frame(x)
        return (total / len(fills)).astype(np.float32)
