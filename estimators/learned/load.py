"""``load_checkpoint``: any saved learned estimator, its class read from the checkpoint.

This module sits above every learned family and imports each one, so every class a
checkpoint may name is registered (:data:`~estimators.learned._checkpoint.CLASSES`)
before one is looked up: no module below imports a family above it, by name or through
``importlib``. A new family is added to the imports here.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from . import _checkpoint as ckpt
from . import blend, context_blend, ensemble, prior  # noqa: F401  (each registers its classes)
from .neural import _NeuralInpainter

__all__ = ["load_checkpoint"]


def load_checkpoint(path: str | os.PathLike) -> Any:
    """Load any saved learned inpainter (its class is read from the checkpoint).

    Parameters
    ----------
    path : path-like
        A model folder written by ``save`` or a training run folder.

    Raises
    ------
    CheckpointError
        If the checkpoint is missing, corrupt, or of an unknown class.
    """
    # Estimators with their own training and file layout (BlendInpainter and its
    # subclasses) load themselves; the step-trained networks share _NeuralInpainter.load.
    config_file = Path(path) / ckpt.CONFIG_FILE
    if config_file.is_file():
        klass = ckpt.checkpoint_class(ckpt._read_json(config_file).get("class"))
        if klass is not None and not issubclass(klass, _NeuralInpainter):
            return klass.load(path)
    return _NeuralInpainter.load(path)
