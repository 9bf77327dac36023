"""Classical (non-learned) depth inpainters; none of them imports torch.

Every class is a scikit-learn estimator that predicts without ``fit`` and processes
the frames of a batch in parallel with ``n_jobs``.
"""

from ._base import in_inverse_depth
from .bilateral import IterativeBilateralInpainter
from .harmonic import HarmonicInpainter
from .ipbasic import IPBasicInpainter
from .mean import MeanInpainter
from .nearest import ConstantInpainter, NearestInpainter
from .opencv import NavierStokesInpainter, TeleaInpainter
from .scanline import ScanlineInpainter

__all__ = [
    "ConstantInpainter",
    "HarmonicInpainter",
    "IPBasicInpainter",
    "IterativeBilateralInpainter",
    "MeanInpainter",
    "NavierStokesInpainter",
    "NearestInpainter",
    "ScanlineInpainter",
    "TeleaInpainter",
    "in_inverse_depth",
]
