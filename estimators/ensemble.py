"""``MeanEnsembleInpainter``, the per-pixel mean of several learned inpainters.

A thin re-export of :mod:`estimators.learned.ensemble`, the import path the docs show
(and that benchmark run folders and pickles record); the code lives in ``estimators/learned/``.
"""

from .learned.ensemble import (
    MeanEnsembleInpainter,
)

__all__ = ["MeanEnsembleInpainter"]
