"""``ContextBlendInpainter``, the learned blend with scene context.

A thin re-export of :mod:`estimators.learned.context_blend`, kept as the import path of
the other learned families (and that benchmark run folders and pickles record); the code
lives in ``estimators/learned/``.
"""

from .learned import context_blend as _module
from .learned.context_blend import (
    ContextBlendInpainter,
)

__all__ = [
    "ContextBlendInpainter",
]

# The module's other names too, private ones included, as before the move to learned/
# (scripts written then import them from here).
globals().update({k: v for k, v in vars(_module).items() if not k.startswith("__") and k not in globals()})
