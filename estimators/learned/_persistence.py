"""The learned format of ``save`` / ``load`` and the class registration: per-class config hooks.

``save`` / ``load`` themselves are :class:`estimators._persistence.SaveLoadMixin`'s (the one
pair of every estimator); :class:`PersistenceMixin` is their learned format: a saved model
is a folder whose ``config.json`` records its class (see
:mod:`~estimators.learned._checkpoint` for the files). Each family says only what is its own:

``_config()``
    ``(config, weights)``: the JSON-able entries of its config (``params`` and whatever
    fitted state it keeps) and its named weight tensors.
``_from_config(config, weights, where)``
    The estimator those describe, built in memory from checked values (``where`` names
    the checkpoint in errors).

The mixin adds the class name and the provenance (training drives, machine) to the
config, writes and reads the files, dispatches a load on the recorded class, and marks
the result fitted. A checkpoint's class is found among the public classes of
:mod:`estimators.learned` that derive from the mixin and are defined (:func:`defined_classes`:
Python's own record of subclasses, so a class is known where it is defined and nothing
registers it by hand); :func:`estimators.learned.load` lists every family it loads, so all
are defined when it reads a checkpoint. An ensemble nests its members' configs (see
:class:`~estimators.learned.MeanEnsembleInpainter`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import torch
from sklearn.exceptions import NotFittedError

from .._persistence import SaveLoadMixin
from . import _checkpoint as ckpt

__all__ = ["CheckpointMixin", "PersistenceMixin", "defined_classes"]


class PersistenceMixin(SaveLoadMixin):
    """The learned format of ``save`` / ``load`` (a checkpoint folder), ``from_config`` and the
    class registration, on top of two per-class hooks."""

    _load_error = ckpt.CheckpointError

    def _config(self) -> tuple[dict[str, Any], dict[str, torch.Tensor]]:
        raise NotImplementedError(f"{type(self).__name__} defines no _config(): it cannot be saved")

    @classmethod
    def _from_config(cls, config: dict[str, Any], weights: dict[str, torch.Tensor], where: Any) -> Any:
        raise NotImplementedError(f"{cls.__name__} defines no _from_config(): it cannot be loaded")

    def to_config(self) -> tuple[dict[str, Any], dict[str, torch.Tensor]]:
        """The full config (class, own entries, provenance) and the weights :meth:`save` writes.

        Raises
        ------
        sklearn.exceptions.NotFittedError
            The estimator is not fitted (a ``ValueError``).
        """
        self._require_saveable()
        config, weights = self._config()
        return {"class": type(self).__name__, **config, **ckpt.provenance(self)}, weights

    @classmethod
    def from_config(cls, config: dict[str, Any], weights: dict[str, torch.Tensor], where: Any) -> Any:
        """The model a checkpoint's ``config`` and (checked) ``weights`` describe, built in memory
        by the class the config records (this class or a subclass).

        Raises
        ------
        CheckpointError
            A class this version does not know, or one that is not ``cls``.
        """
        return cls._loaded_class(config, where)._from_state(config, weights, where)

    # -- the hooks of SaveLoadMixin (save / load): a checkpoint folder ---------------------
    def _is_saveable(self) -> bool:
        return bool(getattr(self, "is_fitted_", False) or hasattr(self, "model_"))

    def _save_state(self) -> tuple[dict[str, Any], dict[str, torch.Tensor]]:
        return self.to_config()

    @classmethod
    def _write_state(cls, path: Path, config: dict[str, Any], weights: dict[str, torch.Tensor]) -> Path:
        return ckpt.write_checkpoint(path, config, weights)

    @classmethod
    def _read_state(cls, path: Path) -> tuple[dict[str, Any], dict[str, torch.Tensor], Path]:
        # A model folder, or a training run folder's best (else last) checkpoint.
        return ckpt.read_model(path)

    @classmethod
    def _state_class(cls, config: dict[str, Any], where: Any) -> type:
        return ckpt.recorded_class(config, where, defined_classes())

    @classmethod
    def _from_state(cls, config: dict[str, Any], weights: dict[str, torch.Tensor], where: Any) -> Any:
        return ckpt.from_checked(cls, config, weights, where)


def defined_classes() -> dict[str, type]:
    """Class name -> class, for every public class of :mod:`estimators.learned` defined so far
    that derives from :class:`PersistenceMixin`.

    A subclass defined elsewhere (a test's, a user's) never takes over the name a shipped
    checkpoint records: only the package's own modules count.
    """
    found: dict[str, type] = {}
    todo = list(PersistenceMixin.__subclasses__())
    while todo:
        klass = todo.pop()
        todo.extend(klass.__subclasses__())
        if klass.__module__.startswith("estimators.learned.") and not klass.__name__.startswith("_"):
            found.setdefault(klass.__name__, klass)
    return found


class CheckpointMixin(PersistenceMixin):
    """The hooks of the step-trained networks (:class:`~estimators.learned._neural._NeuralInpainter`):
    parameters, seed, steps and history as JSON, the network's state dict as weights."""

    def _config(self) -> tuple[dict[str, Any], dict[str, torch.Tensor]]:
        if not hasattr(self, "model_"):
            raise NotFittedError(f"this {type(self).__name__} is not fitted; nothing to save")
        # The config is written from the current parameters: they must still describe the weights.
        self._check_model_params()
        config = {
            "params": self._config_params(),
            "seed": getattr(self, "seed_", None),
            "fitted": {"n_steps_": getattr(self, "n_steps_", 0), "history_": getattr(self, "history_", None)},
        }
        return config, ckpt.cpu_state(self.model_)

    @classmethod
    def _from_config(cls, config: dict[str, Any], weights: dict[str, torch.Tensor], where: Any) -> Any:
        params = dict(ckpt.config_value(config, "params", dict, where))
        if params.get("crop") is not None:
            params["crop"] = tuple(ckpt.config_value(params, "crop", list, where))
        fitted = ckpt.config_value(config, "fitted", dict, where, default={})
        n_steps = ckpt.config_value(fitted, "n_steps_", int, where,
                                    default=ckpt.config_value(fitted, "step", int, where, default=0))
        history = ckpt.config_value(fitted, "history_", dict, where, default=None)
        seed = ckpt.config_value(config, "seed", int, where, default=None)
        est = ckpt.build_checked(cls, params, where)
        est.model_ = ckpt.load_weights(est._build_model(0), weights, where)
        est.history_ = history or ckpt.progress_history(fitted)
        est.n_steps_ = n_steps
        est.seed_ = seed
        est.model_params_ = est._model_params()
        return est
