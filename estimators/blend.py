"""``BlendInpainter``, the learned per-pixel blend of classical fills.

A thin re-export of :mod:`estimators.learned.blend`, kept as the import path the docs
show (and that benchmark run folders and pickles record); the code lives in
``estimators/learned/``.
"""

from .learned import blend as _module
from .learned.blend import (
    BLEND_CANDIDATES,
    BlendInpainter,
)

__all__ = [
    "BLEND_CANDIDATES",
    "BlendInpainter",
]

# The module's other names too, private ones included, as before the move to learned/
# (scripts written then import them from here).
globals().update({k: v for k, v in vars(_module).items() if not k.startswith("__") and k not in globals()})
