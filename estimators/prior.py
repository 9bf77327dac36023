"""``PriorUNetInpainter`` and its shipped releases.

A thin re-export of :mod:`estimators.learned.prior`, kept as the import path the docs
show (and that benchmark run folders and pickles record); the code lives in
``estimators/learned/``.
"""

from .learned import prior as _module
from .learned.prior import (
    ARCHS,
    DEFAULT_PRETRAINED,
    PRETRAINED_DIR,
    PriorUNetInpainter,
    available_pretrained,
    pretrained_kitti,
)

__all__ = [
    "ARCHS",
    "DEFAULT_PRETRAINED",
    "PRETRAINED_DIR",
    "PriorUNetInpainter",
    "available_pretrained",
    "pretrained_kitti",
]

# The module's other names too, private ones included, as before the move to learned/
# (scripts written then import them from here).
globals().update({k: v for k, v in vars(_module).items() if not k.startswith("__") and k not in globals()})
