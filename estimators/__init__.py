"""Depth inpainting methods as scikit-learn estimators.

The shared API (:mod:`~estimators.base`, :mod:`~estimators.scoring`), the classical fills
(:mod:`estimators.classical`, no torch) and the learned ones (:mod:`estimators.learned`,
PyTorch). Classical methods import without torch; the learned ones load torch on first use
and need the ``[learned]`` extra (``pip install "inpaintenv[learned]"``): without it,
``from estimators import UNetInpainter`` raises an ``ImportError`` saying so.
"""

from __future__ import annotations

from .base import BaseInpainter
from .classical import (
    ConstantInpainter,
    HarmonicInpainter,
    IPBasicInpainter,
    IterativeBilateralInpainter,
    NavierStokesInpainter,
    NearestInpainter,
    ScanlineInpainter,
    TeleaInpainter,
)
from .intervals import ConformalIntervalInpainter  # no torch: per-pixel intervals around any fitted inpainter
from .scoring import (
    all_rmse_scorer,
    hole_mae_scorer,
    hole_psnr_scorer,
    hole_rmse_scorer,
    make_inpaint_scorer,
)

__all__ = [
    "BaseInpainter",
    "ConformalIntervalInpainter",
    "ConstantInpainter",
    "HarmonicInpainter",
    "IPBasicInpainter",
    "IterativeBilateralInpainter",
    "NavierStokesInpainter",
    "NearestInpainter",
    "ScanlineInpainter",
    "TeleaInpainter",
    "all_rmse_scorer",
    "hole_mae_scorer",
    "hole_psnr_scorer",
    "hole_rmse_scorer",
    "make_inpaint_scorer",
    "UNetInpainter",
    "AutoencoderInpainter",
    "PriorUNetInpainter",
    "BlendInpainter",
    "ContextBlendInpainter",
    "MeanEnsembleInpainter",
    "load",
    "load_release",
]

#: Exported lazily so that ``import estimators`` never imports torch: name -> module of
#: :mod:`estimators.learned` (``load``: any saved model; ``load_release``: a shipped one by name).
_NEURAL = {"UNetInpainter": "learned._neural", "AutoencoderInpainter": "learned._neural",
           "PriorUNetInpainter": "learned._prior", "BlendInpainter": "learned._blend",
           "ContextBlendInpainter": "learned._context_blend", "MeanEnsembleInpainter": "learned._ensemble",
           "load": "learned._load", "load_release": "learned.releases"}


def __getattr__(name: str):
    if name in _NEURAL:
        import importlib

        from inpaintenv.methods.registry import require_learned

        require_learned(f"estimators.{name} (a learned model)")
        return getattr(importlib.import_module(f".{_NEURAL[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_NEURAL))
