"""``load``: any saved learned estimator, its class read from the checkpoint's ``config.json``.

This module sits above every learned family and imports each one, so every class a
checkpoint may name is registered (each registers itself when defined:
:class:`~estimators.learned._persistence.PersistenceMixin`) before one is looked up: no
module below imports a family above it, by name or through ``importlib``. A new family is
added to the imports here.
"""

from __future__ import annotations

import os
from typing import Any

from . import _blend, _context_blend, _ensemble, _neural, _prior, _scan_blend  # noqa: F401  (each registers its classes)
from ._persistence import PersistenceMixin

__all__ = ["load"]


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
