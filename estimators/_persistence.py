"""The checks every ``save`` / ``load`` makes, as plain functions (torch-free).

Each family of saveable estimators has one persistence mixin, in the shape of
segmentation_models_pytorch's hub mixin: ``save`` / ``load`` on the mixin, the family's
own part in two hooks on its classes (``_config()`` / ``_from_config()``), and its file
format in plain functions:

* :class:`estimators.learned._persistence.PersistenceMixin`: a checkpoint folder
  (:mod:`estimators.learned._checkpoint`);
* :class:`estimators.intervals._persistence.CalibrationFileMixin`: a calibration JSON file
  (:mod:`estimators.intervals._calibration_file`).

Both check the path, the options and that there is something to save with the functions
below, and name the file in the one error a load that cannot read it raises.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

from sklearn.exceptions import NotFittedError

from inpaintenv.exceptions import InpaintenvError, InvalidTypeError

__all__ = ["as_path", "check_loaded_class", "check_options", "read_or_fail", "require_saveable"]

T = TypeVar("T")


def as_path(path: Any, method: str) -> Path:
    """``path`` as a :class:`~pathlib.Path` (a str or path-like; ``method`` names the caller in the error)."""
    if isinstance(path, (str, os.PathLike)) and not isinstance(os.fspath(path), bytes):
        return Path(path)
    raise InvalidTypeError(f"{method}: path must be a str or path-like, got {type(path).__name__}")


def check_options(cls: type, method: str, options: dict[str, Any], accepted: tuple[str, ...]) -> None:
    """Refuse keyword options of ``cls.method`` that its format does not take."""
    unknown = sorted(set(options) - set(accepted))
    if unknown:
        takes = ", ".join(f"{k}=" for k in accepted) or "no options"
        raise InvalidTypeError(f"{cls.__name__}.{method}() got unexpected option(s) {unknown}; it takes {takes}")


def require_saveable(est: Any, saveable: bool) -> None:
    """Raise sklearn's ``NotFittedError`` (a ``ValueError``) when there is nothing to save."""
    if not saveable:
        raise NotFittedError(f"this {type(est).__name__} is not fitted; call fit first (nothing to save)")


def read_or_fail(read: Callable[[Path], T], source: Path, error: type[InpaintenvError]) -> T:
    """``read(source)``, a plain ``OSError`` turned into one ``error`` naming the file."""
    try:
        return read(source)
    except OSError as exc:
        if isinstance(exc, InpaintenvError):
            raise
        text = exc.strerror or str(exc)  # the file layer's message names the file already
        raise error(text if str(source) in text else f"{source}: cannot be read ({text})") from None


def check_loaded_class(cls: type, klass: type, where: Any, error: type[InpaintenvError]) -> type:
    """``klass`` (the class the files record) if it is ``cls`` or a subclass, else one ``error``."""
    if not issubclass(klass, cls):
        raise error(f"{where} holds a {klass.__name__!r}, not a {cls.__name__}")
    return klass
