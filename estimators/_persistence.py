"""``save`` / ``load`` of every estimator that can be saved: one template, one format per family.

Torch-free: the interval wrapper, which wraps classical methods too, saves through it
without the ``[learned]`` extra. As in segmentation_models_pytorch's hub mixin, the public
methods do the common part once and a family says only what is its own:

``_save_state(**options)``
    ``(config, payload)``: the JSON-able config and whatever else the files hold (a learned
    model's weights; None for an interval calibration).
``_write_state(path, config, payload)`` / ``_read_state(path)``
    The family's files: how they are written (returning the written path) and read
    (returning ``(config, payload, where)``, ``where`` naming the file in errors), each
    through :mod:`inpaintenv.files`.
``_state_class(config, where)``
    The class the files record (this class by default); ``load`` refuses one that is not
    the class it was called on or a subclass.
``_from_state(config, payload, where, **options)``
    The estimator those describe, built in memory (called on the recorded class).

``save`` checks that there is something to save (:meth:`SaveLoadMixin._is_saveable`,
sklearn's fitted test by default) and the path; ``load`` checks the path, dispatches on
the recorded class and names the file in its one error (``_load_error``). The families:
:class:`estimators.learned._persistence.PersistenceMixin` (a checkpoint folder) and
:class:`estimators.intervals._persistence.CalibrationFileMixin` (a calibration JSON file).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from sklearn.exceptions import NotFittedError

from inpaintenv.exceptions import InpaintenvError, InvalidInputError, InvalidTypeError

__all__ = ["SaveLoadMixin"]


def _as_path(path: Any, method: str) -> Path:
    if isinstance(path, (str, os.PathLike)) and not isinstance(os.fspath(path), bytes):
        return Path(path)
    raise InvalidTypeError(f"{method}: path must be a str or path-like, got {type(path).__name__}")


class SaveLoadMixin:
    """The one public ``save`` / ``load`` pair, over per-family hooks (see the module docstring)."""

    #: Keyword options ``save`` / ``load`` pass on to ``_save_state`` / ``_from_state``.
    _save_options: tuple[str, ...] = ()
    _load_options: tuple[str, ...] = ()
    #: The error of a file that cannot be loaded (a family narrows it; the message names the file).
    _load_error: type[InpaintenvError] = InvalidInputError

    # -- the hooks of a family ---------------------------------------------------------
    def _is_saveable(self) -> bool:
        """Whether there is something to save: sklearn's fitted test by default."""
        fitted = getattr(self, "__sklearn_is_fitted__", None)
        if fitted is not None:
            return bool(fitted())
        return any(k.endswith("_") and not k.startswith("__") for k in vars(self))

    def _save_state(self, **options: Any) -> tuple[dict[str, Any], Any]:
        raise NotImplementedError(f"{type(self).__name__} defines no _save_state(): it cannot be saved")

    @classmethod
    def _write_state(cls, path: Path, config: dict[str, Any], payload: Any) -> Path:
        raise NotImplementedError(f"{cls.__name__} defines no _write_state(): it cannot be saved")

    @classmethod
    def _read_state(cls, path: Path) -> tuple[dict[str, Any], Any, Any]:
        raise NotImplementedError(f"{cls.__name__} defines no _read_state(): it cannot be loaded")

    @classmethod
    def _state_class(cls, config: dict[str, Any], where: Any) -> type:
        return cls

    @classmethod
    def _from_state(cls, config: dict[str, Any], payload: Any, where: Any, **options: Any) -> Any:
        raise NotImplementedError(f"{cls.__name__} defines no _from_state(): it cannot be loaded")

    # -- the common part ---------------------------------------------------------------
    def _require_saveable(self) -> None:
        """Raise sklearn's ``NotFittedError`` (a ``ValueError``) when there is nothing to save."""
        if not self._is_saveable():
            raise NotFittedError(f"this {type(self).__name__} is not fitted; call fit first (nothing to save)")

    @classmethod
    def _check_options(cls, method: str, options: dict[str, Any], accepted: tuple[str, ...]) -> None:
        unknown = sorted(set(options) - set(accepted))
        if unknown:
            takes = ", ".join(f"{k}=" for k in accepted) or "no options"
            raise InvalidTypeError(f"{cls.__name__}.{method}() got unexpected option(s) {unknown}; it takes {takes}")

    @classmethod
    def _loaded_class(cls, config: dict[str, Any], where: Any) -> type:
        """The class the files record, if it is ``cls`` or a subclass (else ``_load_error``)."""
        klass = cls._state_class(config, where)
        if not issubclass(klass, cls):
            raise cls._load_error(f"{where} holds a {klass.__name__!r}, not a {cls.__name__}")
        return klass

    def save(self, path: str | os.PathLike, **options: Any) -> Path:
        """Write the fitted estimator to ``path`` in its family's format.

        Parameters
        ----------
        path : path-like
            A learned model's folder (``config.json`` + ``model.safetensors``) or an interval
            calibration's ``.json`` file; written atomically, never through a planted link.
        **options
            Keyword options of the family's format (``_save_options``): none for a learned
            model; ``base=`` for an interval calibration, how :meth:`load` rebuilds the
            base without ``estimator=`` (a registered method name such as ``"scanline"``
            or ``"pretrained"``, or a model folder; the base's class name by default).

        Returns
        -------
        pathlib.Path
            What was written; :meth:`load` reads it back.

        Raises
        ------
        sklearn.exceptions.NotFittedError
            The estimator is not fitted (a ``ValueError``).
        InvalidTypeError
            ``path`` is not a path, or an option the format does not take.
        """
        self._check_options("save", options, self._save_options)
        target = _as_path(path, f"{type(self).__name__}.save")
        self._require_saveable()
        config, payload = self._save_state(**options)
        return self._write_state(target, config, payload)

    @classmethod
    def load(cls, path: str | os.PathLike, **options: Any) -> Any:
        """Read an estimator written by :meth:`save`; the class the files record builds it.

        Parameters
        ----------
        path : path-like
            What ``save`` wrote (a learned model's folder, or a training run folder: its
            best, else last, checkpoint; an interval calibration's ``.json`` file).
        **options
            Keyword options of the family's format (``_load_options``): none for a learned
            model; ``estimator=`` for an interval calibration, the fitted base (by
            default rebuilt from the file's ``base``; its class must be the one calibrated).

        Returns
        -------
        estimator
            Fitted, of the class the files record: ``cls`` or a subclass.

        Raises
        ------
        InvalidInputError
            One error naming the file (a learned model's ``CheckpointError``): missing,
            unreadable, truncated, tampered-with or not of this format, or of a class that
            is not ``cls`` (or a subclass).
        InvalidTypeError
            ``path`` is not a path, or an option the format does not take.
        """
        cls._check_options("load", options, cls._load_options)
        source = _as_path(path, f"{cls.__name__}.load")
        try:
            config, payload, where = cls._read_state(source)
        except OSError as exc:
            if isinstance(exc, InpaintenvError):
                raise
            text = exc.strerror or str(exc)  # the file layer's message names the file already
            raise cls._load_error(text if str(source) in text else f"{source}: cannot be read ({text})") from None
        return cls._loaded_class(config, where)._from_state(config, payload, where, **options)
