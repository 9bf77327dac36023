"""What a checkpoint read from disk must satisfy before a model is built from it.

A checkpoint is data from outside (``--checkpoint`` reaches ``evaluate``, ``benchmark`` and
``score``): its weights must be floating point and finite, every config entry of the type
the loaders read, and the estimator it describes must pass its own parameter checks and
size limits (:mod:`estimators.learned._limits`) before any network is allocated. Each
failure is one :class:`CheckpointError` naming the file and the key or tensor.

A path read from a checkpoint is never kept: the parameters that name a file or folder
(:data:`PATH_PARAMS`) are reset to None on load, so a later ``fit`` of a loaded model never
writes (``checkpoint_dir``) or reads (``warm_start``) where a file handed to the user said.
"""

from __future__ import annotations

from typing import Any

import torch

# The project's one class for an unreadable checkpoint (a ValueError; one line in the CLI).
from inpaintenv.exceptions import CheckpointError

__all__ = ["PATH_PARAMS", "CheckpointError", "build_checked", "check_tensors", "config_value", "load_weights",
           "without_paths"]

#: The parameters of the learned estimators that name a file or folder: ``checkpoint_dir``
#: (where ``fit`` writes its training checkpoints) and ``warm_start`` (a saved model ``fit``
#: starts from; ``True``, "the previous fit", is no path and is kept).
PATH_PARAMS: tuple[str, ...] = ("checkpoint_dir", "warm_start")


def check_tensors(tensors: dict[str, torch.Tensor], where: Any) -> dict[str, torch.Tensor]:
    """``tensors`` if each is floating point and finite, else one :class:`CheckpointError`.

    ``load_state_dict`` would cast integer weights silently and NaN weights only show up as
    a NaN prediction, long after loading (the first tensor at fault is named).
    """
    for name, value in tensors.items():
        if not value.is_floating_point():
            raise CheckpointError(f"{where}: tensor {name!r} has dtype {str(value.dtype).removeprefix('torch.')}; "
                                  "network weights are floating point")
        if not bool(torch.isfinite(value).all()):
            raise CheckpointError(f"{where}: tensor {name!r} holds NaN or inf values")
    return tensors


_REQUIRED = object()
_KIND_NAMES = {dict: "a JSON object", list: "a list", str: "a string", int: "an integer", float: "a number",
               bool: "true or false"}


def config_value(config: dict[str, Any], key: str, kind: type | tuple[type, ...], where: Any,
                 default: Any = _REQUIRED) -> Any:
    """``config[key]`` if it is of ``kind`` (``default`` when absent or null), else one
    :class:`CheckpointError` naming ``where`` (the file), the key and the value.

    ``int`` never accepts a bool; ``float`` accepts an int.
    """
    value = config.get(key) if isinstance(config, dict) else None
    if value is None:
        if default is _REQUIRED:
            raise CheckpointError(f"{where}: config.json has no {key!r} ({_kind_name(kind)})")
        return default
    kinds = kind if isinstance(kind, tuple) else (kind,)
    if float in kinds:
        kinds = (*kinds, int)
    if not isinstance(value, kinds) or (isinstance(value, bool) and bool not in kinds):
        shown = repr(value)
        shown = shown if len(shown) <= 60 else shown[:57] + "..."
        raise CheckpointError(f"{where}: config.json {key!r} must be {_kind_name(kind)}, got {shown}")
    return value


def _kind_name(kind: type | tuple[type, ...]) -> str:
    kinds = kind if isinstance(kind, tuple) else (kind,)
    return " or ".join(_KIND_NAMES.get(k, k.__name__) for k in kinds)


def without_paths(params: dict[str, Any]) -> dict[str, Any]:
    """``params`` with every :data:`PATH_PARAMS` entry (other than a bool) set to None."""
    return {k: None if k in PATH_PARAMS and not isinstance(v, bool) else v for k, v in params.items()}


def build_checked(klass: type, params: dict[str, Any], where: Any) -> Any:
    """``klass(**params)`` after its parameter and size checks, or one :class:`CheckpointError`.

    Runs before any network is built, so a tampered size never allocates. Paths in
    ``params`` are dropped (:func:`without_paths`): a loaded model keeps none.
    """
    try:
        est = klass(**without_paths(params))
    except TypeError as e:
        raise CheckpointError(f"{where} has parameters this version does not know: {e}") from None
    try:
        est._check_params()
        est._check_size()
    except (ValueError, TypeError, KeyError) as e:
        raise CheckpointError(f"{where}: {e.args[0] if isinstance(e, KeyError) else e}") from None
    return est


def load_weights(model: torch.nn.Module, weights: dict[str, torch.Tensor], where: Any) -> torch.nn.Module:
    """``model`` in eval mode with ``weights`` loaded, or one :class:`CheckpointError` if they do not fit."""
    try:
        model.load_state_dict(weights)
    except RuntimeError as e:
        raise CheckpointError(f"{where}: weights do not fit the saved architecture: {e}") from None
    return model.eval()
