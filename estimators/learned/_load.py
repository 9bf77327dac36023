"""``load``: any saved learned estimator, its class read from the checkpoint's ``config.json``.

This module sits above every learned family and lists, once, every class a checkpoint may
record (:data:`LOADABLE`); a checkpoint's class is then found among the defined classes
(:func:`~estimators.learned._persistence.defined_classes`). No module below imports a family
above it, by name or through ``importlib``. A new family is added to :data:`LOADABLE`
(``tests/estimators/learned/test_class_registration.py`` fails until it is).
"""

from __future__ import annotations

import os
from typing import Any

from ._blend import BlendInpainter
from ._context_blend import ContextBlendInpainter
from ._ensemble import MeanEnsembleInpainter
from ._neural import AutoencoderInpainter, UNetInpainter
from ._persistence import PersistenceMixin
from ._prior import PriorUNetInpainter
from ._scan_blend import ScanBlendInpainter
from ._sparse_residual import SparseResidualInpainter

__all__ = ["LOADABLE", "load"]

#: Every class a saved learned model may record, by the name its ``config.json`` holds.
LOADABLE: dict[str, type] = {klass.__name__: klass for klass in (
    UNetInpainter, AutoencoderInpainter, PriorUNetInpainter, BlendInpainter, ContextBlendInpainter,
    ScanBlendInpainter, SparseResidualInpainter, MeanEnsembleInpainter)}


def load(path: str | os.PathLike) -> Any:
    """Load any saved learned inpainter: the class its ``config.json`` records reads it.

    The same as ``Cls.load(path)`` of the base of every learned class (``Cls.load`` of one
    family also refuses a checkpoint of another).

    Parameters
    ----------
    path : path-like
        A model folder written by ``save``, or a training run folder (its best, else
        last, checkpoint).

    Raises
    ------
    CheckpointError
        If the checkpoint is missing, corrupt, tampered with, or of a class this version
        does not know.
    """
    return PersistenceMixin.load(path)
