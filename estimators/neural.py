"""The study's U-Net and autoencoder inpainters and ``load_checkpoint``.

A thin re-export of :mod:`estimators.learned.neural`, kept as the import path the docs
show (and that benchmark run folders and pickles record); the code lives in
``estimators/learned/``.
"""

from .learned import neural as _module
from .learned.load import load_checkpoint
from .learned.neural import (
    AutoencoderInpainter,
    CheckpointError,
    UNetInpainter,
)

__all__ = [
    "AutoencoderInpainter",
    "CheckpointError",
    "UNetInpainter",
    "load_checkpoint",
]

# The module's other names too, private ones included, as before the move to learned/
# (scripts written then import them from here).
globals().update({k: v for k, v in vars(_module).items() if not k.startswith("__") and k not in globals()})
