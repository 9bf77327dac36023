"""``save`` / ``load`` of a :class:`~estimators.intervals.ConformalIntervalInpainter`: one small JSON file.

The file holds the calibration, never the base model (``save(path, base=...)`` records how
``load(path)`` rebuilds the base; ``load(path, estimator=...)`` takes it instead). Its format
and every field's check are :mod:`._calibration_file`'s plain functions, read and written
through :mod:`inpaintenv.files`; :class:`CalibrationFileMixin` maps it to and from the
wrapper with the two hooks every persistence mixin has (``_config`` / ``_from_config``, as
the learned one, :class:`estimators.learned._persistence.PersistenceMixin`).
"""

from __future__ import annotations

import copy
import os
from pathlib import Path
from typing import Any

import numpy as np
from sklearn.utils.validation import check_is_fitted

from inpaintenv.exceptions import InvalidInputError, InvalidTypeError

from .._persistence import as_path, check_options, read_or_fail, require_saveable
from ._bases import make_base
from ._calibration_file import FORMAT, read_calibration, write_calibration

__all__ = ["CalibrationFileMixin"]


class CalibrationFileMixin:
    """``save(path, base=None)`` writes the calibration JSON, ``load(path, estimator=None)`` reads it."""

    _save_options = ("base",)
    _load_options = ("estimator",)

    def _config(self, base: str | None = None) -> dict[str, Any]:
        check_is_fitted(self)
        cal = self.calibration_
        if cal["spread_method"] is not None and cal["spread_method"] != self.spread_method:
            raise InvalidInputError(f"spread_method was set to {self.spread_method!r} after calibrating with "
                                    f"{cal['spread_method']!r}: fit again")
        return {
            "format": FORMAT, "base": base if base is not None else cal["base"],
            "base_class": type(self.estimator).__name__,
            # What was calibrated, not parameters set since.
            "params": {"coverage": cal["coverage"], "signals": cal["signals"], "spread_method": self.spread_method,
                       "protocol": cal["protocol"], "seed": cal["seed"], "max_fit_pixels": int(self.max_fit_pixels),
                       "weighting": cal.get("weighting", "pixel")},
            "coef": [float(c) for c in self.coef_], "quantile": self.quantile_,
            "n_pixels": self.n_calibration_pixels_,
            "residual_quantiles": [float(v) for v in self.residual_quantiles_],
            "calibration": copy.deepcopy(cal),  # a caller editing the dict leaves the wrapper as is
            # Only a conditioned calibration has the field: an unconditioned file is as it always was.
            **({"condition": copy.deepcopy(cond)} if (cond := getattr(self, "condition_", None)) is not None else {}),
        }

    @classmethod
    def _from_config(cls, data: dict[str, Any], path: Any, estimator: Any = None) -> Any:
        """A fitted ``cls`` around ``estimator`` (rebuilt from ``data["base"]`` by default) from the
        checked calibration ``data`` of the file ``path``."""
        if estimator is None:
            estimator = make_base(data["base"])
        if type(estimator).__name__ != data["base_class"]:
            raise InvalidInputError(f"{path}: calibrated for a {data['base_class']}, got a {type(estimator).__name__}")
        params = data["params"]
        out = cls(estimator, coverage=params["coverage"], signals=tuple(params["signals"]),
                  spread_method=params["spread_method"], protocol=params["protocol"], seed=params["seed"],
                  max_fit_pixels=params["max_fit_pixels"], weighting=params.get("weighting", "pixel"),
                  condition=(data.get("condition") or {}).get("variable"),
                  condition_edges=(data.get("condition") or {}).get("edges"))
        try:
            out._check_params()
        except (InvalidInputError, InvalidTypeError, KeyError) as exc:
            raise InvalidInputError(f"{path}: {exc.args[0] if isinstance(exc, KeyError) else exc}") from None
        out.coef_ = np.asarray(data["coef"], dtype=np.float64)
        out.residual_quantiles_ = np.asarray(data["residual_quantiles"], dtype=np.float64)
        out.quantile_ = float(data["quantile"])
        out.n_calibration_pixels_ = int(data["n_pixels"])
        out.calibration_ = copy.deepcopy(data["calibration"])
        out.calibration_.setdefault("weighting", out.weighting)
        out.condition_ = copy.deepcopy(data.get("condition"))
        return out

    def to_dict(self, base: str | None = None) -> dict[str, Any]:
        """The calibration as plain JSON types (what :meth:`save` writes; ``base`` as there)."""
        return self._config(base)

    def save(self, path: str | os.PathLike, **options: Any) -> Path:
        """Write the fitted wrapper's calibration to the JSON file ``path`` (atomically).

        Parameters
        ----------
        path : path-like
            The ``.json`` file; written atomically, never through a planted link.
        **options
            ``base=``: how :meth:`load` rebuilds the base without ``estimator=`` (a
            registered method name such as ``"scanline"`` or ``"pretrained"``, or a model
            folder; the base's class name by default).

        Returns
        -------
        pathlib.Path
            What was written; :meth:`load` reads it back.

        Raises
        ------
        sklearn.exceptions.NotFittedError
            The wrapper is not fitted (a ``ValueError``).
        InvalidTypeError
            ``path`` is not a path, or an option other than ``base``.
        """
        check_options(type(self), "save", options, self._save_options)
        target = as_path(path, f"{type(self).__name__}.save")
        require_saveable(self, bool(self.__sklearn_is_fitted__()))
        return write_calibration(target, self._config(**options))

    @classmethod
    def load(cls, path: str | os.PathLike, **options: Any) -> Any:
        """Read a calibration written by :meth:`save` around its base.

        Parameters
        ----------
        path : path-like
            The calibration's ``.json`` file.
        **options
            ``estimator=``: the fitted base (by default rebuilt from the file's ``base``; its
            class must be the one calibrated).

        Returns
        -------
        ConformalIntervalInpainter
            Fitted.

        Raises
        ------
        InvalidInputError
            One error naming the file: missing, unreadable, truncated, tampered-with or not
            of this format (and the field), or calibrated for another base class.
        InvalidTypeError
            ``path`` is not a path, or an option other than ``estimator``.
        """
        check_options(cls, "load", options, cls._load_options)
        source = as_path(path, f"{cls.__name__}.load")
        data = read_or_fail(read_calibration, source, InvalidInputError)  # every field checked
        return cls._from_config(data, source, **options)
