"""``save`` / ``load`` of every learned estimator: one mixin over two per-class hooks.

A saved model is a checkpoint folder whose ``config.json`` records its class; the files
are :mod:`~estimators.learned._checkpoint`'s plain functions. Each class says only what is
its own:

``_config()``
    ``(config, weights)``: the JSON-able entries of its config (``params`` and whatever
    fitted state it keeps) and its named weight tensors.
``_from_config(config, weights, where)``
    The estimator those describe, built in memory from checked values (``where`` names
    the checkpoint in errors).

A load is three steps: :meth:`PersistenceMixin.load` reads the folder
(:func:`~estimators.learned._checkpoint.read_model`), finds the class ``config.json``
records among the public learned classes defined so far (:func:`defined_classes`: Python's
own record of subclasses, so nothing registers a class by hand) and calls its
``_from_config``. :func:`estimators.learned.load` lists every family it loads, so all are
defined when it reads a checkpoint. An ensemble nests its members' configs (see
:class:`~estimators.learned.MeanEnsembleInpainter`).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
import torch

from .._persistence import as_path, check_loaded_class, check_options, read_or_fail, require_saveable
from . import _checkpoint as ckpt

__all__ = ["PersistenceMixin", "defined_classes", "json_params"]


class PersistenceMixin:
    """``save`` / ``load`` (a checkpoint folder), ``to_config`` / ``from_config``, over the
    per-class hooks ``_config`` / ``_from_config`` (see the module docstring)."""

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
        require_saveable(self, bool(getattr(self, "is_fitted_", False) or hasattr(self, "model_")))
        config, weights = self._config()
        return {"class": type(self).__name__, **config, **ckpt.provenance(self)}, weights

    @classmethod
    def from_config(cls, config: dict[str, Any], weights: dict[str, torch.Tensor], where: Any) -> Any:
        """The model a checkpoint's ``config`` and (checked) ``weights`` describe, built in memory
        by the ``_from_config`` of the class the config records (this class or a subclass), with
        its provenance (``training_drives_``, ``fit_environment_``), fitted.

        Raises
        ------
        CheckpointError
            A class this version does not know, or one that is not ``cls``.
        """
        klass = ckpt.recorded_class(config, where, defined_classes())
        klass = check_loaded_class(cls, klass, where, ckpt.CheckpointError)
        est = klass._from_config(config, weights, where)
        ckpt.restore_provenance(est, config)
        est.is_fitted_ = True
        return est

    def save(self, path: str | os.PathLike, **options: Any) -> Path:
        """Write the fitted estimator to the folder ``path`` (``config.json`` + ``model.safetensors``).

        Parameters
        ----------
        path : path-like
            The folder; written atomically, never through a planted link.
        **options
            None (the signature is the interval calibration's, which takes ``base=``).

        Returns
        -------
        pathlib.Path
            What was written; :meth:`load` reads it back.

        Raises
        ------
        sklearn.exceptions.NotFittedError
            The estimator is not fitted (a ``ValueError``).
        InvalidTypeError
            ``path`` is not a path, or an option is given.
        """
        check_options(type(self), "save", options, ())
        target = as_path(path, f"{type(self).__name__}.save")
        config, weights = self.to_config()
        return ckpt.write_checkpoint(target, config, weights)

    @classmethod
    def load(cls, path: str | os.PathLike, **options: Any) -> Any:
        """Read an estimator written by :meth:`save`; the class ``config.json`` records builds it.

        Parameters
        ----------
        path : path-like
            A model folder written by ``save``, or a training run folder (its best, else
            last, checkpoint).
        **options
            None (the signature is the interval calibration's, which takes ``estimator=``).

        Returns
        -------
        estimator
            Fitted, of the class the files record: ``cls`` or a subclass.

        Raises
        ------
        CheckpointError
            One error naming the file: missing, unreadable, truncated, tampered-with or not
            of this format, or of a class that is not ``cls`` (or a subclass).
        InvalidTypeError
            ``path`` is not a path, or an option is given.
        """
        check_options(cls, "load", options, ())
        source = as_path(path, f"{cls.__name__}.load")
        config, weights, where = read_or_fail(ckpt.read_model, source, ckpt.CheckpointError)
        return cls.from_config(config, weights, where)


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


def json_params(est: Any) -> dict[str, Any]:
    """``est.get_params()`` as a config records it: tuples as lists, a random generator as the seed its fit
    drew (``seed_``; None before a fit), since neither is JSON."""
    params = {k: (list(v) if isinstance(v, tuple) else v) for k, v in est.get_params().items()}
    if isinstance(params.get("random_state"), (np.random.RandomState, np.random.Generator)):
        params["random_state"] = getattr(est, "seed_", None)
    return params
