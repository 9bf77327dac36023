"""The calibration-file format of ``save`` / ``load`` of a :class:`~estimators.intervals.ConformalIntervalInpainter`.

``save`` / ``load`` themselves are :class:`estimators._persistence.SaveLoadMixin`'s (the one
pair of every estimator); :class:`CalibrationFileMixin` is their interval format: one small
JSON file holding the calibration, never the base model (``save(path, base=...)`` records
how ``load(path)`` rebuilds the base; ``load(path, estimator=...)`` takes it instead). The
file itself (its format and every field's check) is :mod:`._calibration_file`'s, read and
written through :mod:`inpaintenv.files`; this module maps it to and from the wrapper.
"""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import numpy as np
from sklearn.utils.validation import check_is_fitted

from inpaintenv.exceptions import InvalidInputError, InvalidTypeError

from .._persistence import SaveLoadMixin
from ._bases import make_base
from ._calibration_file import FORMAT, read_calibration, write_calibration

__all__ = ["CalibrationFileMixin", "calibration_dict", "wrapper_from_calibration"]


def calibration_dict(wrapper: Any, base: str | None = None) -> dict[str, Any]:
    """``wrapper``'s calibration as plain JSON types (what ``save`` writes)."""
    check_is_fitted(wrapper)
    cal = wrapper.calibration_
    if cal["spread_method"] is not None and cal["spread_method"] != wrapper.spread_method:
        raise InvalidInputError(f"spread_method was set to {wrapper.spread_method!r} after calibrating with "
                                f"{cal['spread_method']!r}: fit again")
    return {
        "format": FORMAT, "base": base if base is not None else cal["base"],
        "base_class": type(wrapper.estimator).__name__,
        # What was calibrated, not parameters set since.
        "params": {"coverage": cal["coverage"], "signals": cal["signals"], "spread_method": wrapper.spread_method,
                   "protocol": cal["protocol"], "seed": cal["seed"], "max_fit_pixels": int(wrapper.max_fit_pixels),
                   "weighting": cal.get("weighting", "pixel")},
        "coef": [float(c) for c in wrapper.coef_], "quantile": wrapper.quantile_,
        "n_pixels": wrapper.n_calibration_pixels_,
        "residual_quantiles": [float(v) for v in wrapper.residual_quantiles_],
        "calibration": copy.deepcopy(cal),  # a caller editing the dict leaves the wrapper as is
    }


def wrapper_from_calibration(cls: type, data: dict[str, Any], path: Any, estimator: Any = None) -> Any:
    """A fitted ``cls`` around ``estimator`` (rebuilt from ``data["base"]`` by default) from the
    checked calibration ``data`` of the file ``path``."""
    if estimator is None:
        estimator = make_base(data["base"])
    if type(estimator).__name__ != data["base_class"]:
        raise InvalidInputError(f"{path}: calibrated for a {data['base_class']}, got a {type(estimator).__name__}")
    params = data["params"]
    out = cls(estimator, coverage=params["coverage"], signals=tuple(params["signals"]),
              spread_method=params["spread_method"], protocol=params["protocol"], seed=params["seed"],
              max_fit_pixels=params["max_fit_pixels"],
              # Files written before the frame weighting were calibrated by pixel.
              weighting=params.get("weighting", "pixel"))
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
    return out


class CalibrationFileMixin(SaveLoadMixin):
    """The hooks of :class:`~estimators._persistence.SaveLoadMixin` for an interval calibration:
    ``save(path, base=None)`` writes the calibration JSON, ``load(path, estimator=None)`` reads it."""

    _save_options = ("base",)
    _load_options = ("estimator",)

    def to_dict(self, base: str | None = None) -> dict[str, Any]:
        """The calibration as plain JSON types (what :meth:`save` writes; ``base`` as there)."""
        return calibration_dict(self, base)

    def _save_state(self, base: str | None = None) -> tuple[dict[str, Any], None]:
        return self.to_dict(base), None

    @classmethod
    def _write_state(cls, path: Path, config: dict[str, Any], payload: None) -> Path:
        return write_calibration(path, config)

    @classmethod
    def _read_state(cls, path: Path) -> tuple[dict[str, Any], None, Path]:
        return read_calibration(path), None, path  # every field checked; one error naming the file and the field

    @classmethod
    def _from_state(cls, config: dict[str, Any], payload: None, where: Any, estimator: Any = None) -> Any:
        return wrapper_from_calibration(cls, config, where, estimator)
