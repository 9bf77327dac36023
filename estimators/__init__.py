"""Depth inpainting methods as scikit-learn estimators.

This package's own API is what every method shares: :class:`BaseInpainter` (from
:mod:`~estimators.base`) and the hole scorers (from :mod:`~estimators.scoring`). The methods
live in their subpackages, each name at one path:

- :mod:`estimators.classical`: the classical fills (no torch), e.g.
  ``from estimators.classical import HarmonicInpainter``;
- :mod:`estimators.learned`: the learned ones, ``load`` and ``load_release`` (PyTorch, the
  ``[learned]`` extra: ``pip install "inpaintenv[learned]"``; without it,
  ``from estimators.learned import UNetInpainter`` raises an ``ImportError`` saying so);
- :mod:`estimators.intervals`: per-pixel intervals around any fitted inpainter (no torch).
"""

from __future__ import annotations

from . import classical, intervals, learned
from .base import BaseInpainter
from .scoring import (
    all_rmse_scorer,
    hole_mae_scorer,
    hole_psnr_scorer,
    hole_rmse_scorer,
    make_inpaint_scorer,
)

__all__ = [
    "BaseInpainter",
    "all_rmse_scorer",
    "classical",
    "hole_mae_scorer",
    "hole_psnr_scorer",
    "hole_rmse_scorer",
    "intervals",
    "learned",
    "make_inpaint_scorer",
]


def __getattr__(name: str):
    # A method class asked of the package face: say where its one public path is.
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}; the methods are in estimators.classical, "
                         "estimators.learned and estimators.intervals")
