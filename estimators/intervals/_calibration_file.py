"""An interval calibration file: read through the safe file layer and every field checked for what it can mean.

A calibration (``ConformalIntervalInpainter.save``) is data from outside: ``--intervals``
and ``ConformalIntervalInpainter.load`` read files a user was handed. A tampered one
(a negative quantile, a huge negative scale coefficient, negative residual quantiles)
would give intervals of zero width with no error, so each field is checked against what
calibration can produce, and the first that breaks its rule is one
:class:`~inpaintenv.exceptions.InvalidInputError` naming the file and the field:

``coef``
    ``1 + len(signals)`` finite numbers of at most :data:`MAX_ABS_COEF` in size: the least
    squares of ``log(|residual| + 0.05 m)`` (between -3 and 5.6) on log-signals.
``residual_quantiles``
    :data:`N_LEVELS` finite, non-negative, non-decreasing numbers (quantiles of a ratio
    of a non-negative residual to a positive scale).
``quantile``
    A positive finite number between the stored quantiles on either side of the
    calibrated coverage (both weightings' levels taken, so a file of either reads).
``n_pixels``, ``n_frames``
    Integers >= 1; ``n_pixels`` enough for the coverage (``ceil((n + 1) c) <= n``), the
    same at the top and in ``calibration``; out-of-fold records add up to them.
``params`` / ``calibration``
    Coverage in (0, 1), known signals without repeats, a known weighting, strings where
    names are, a non-negative integer seed, and the two copies of what was calibrated
    agreeing.

The file is read with :func:`inpaintenv.files.read_json` (regular files only, bounded
size and nesting, no NaN or Infinity) and written with :func:`inpaintenv.files.write_json`
(an exclusive, unpredictably named temporary renamed over the target).
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from inpaintenv.exceptions import InvalidInputError
from inpaintenv.files import read_json, write_json

__all__ = ["DEFAULT_SIGNALS", "FORMAT", "MAX_ABS_COEF", "MAX_CALIBRATION_BYTES", "N_LEVELS", "SIGNALS", "WEIGHTINGS",
           "read_calibration", "write_calibration"]

FORMAT = "inpaintenv-conformal-intervals-v1"
#: The signals a scale model may use (``"far"``: ``estimators.intervals._calibration.features``).
SIGNALS: tuple[str, ...] = ("border", "depth", "spread", "far")
#: The signals a wrapper uses unless told otherwise.
DEFAULT_SIGNALS: tuple[str, ...] = ("border", "depth", "spread")
#: How the calibration pixels weigh in the quantile.
WEIGHTINGS: tuple[str, ...] = ("frame", "pixel")
#: Levels at which the sorted normalised residuals are kept (0, 0.0005, ..., 1).
N_LEVELS = 2001
#: Largest size of a scale coefficient: the shipped ones are below 4; 20 already makes the
#: scale change by e^20 over one unit of a log-signal.
MAX_ABS_COEF = 20.0
#: Largest calibration file read (a calibration is about 60 kB; the drive lists grow it a little).
MAX_CALIBRATION_BYTES = 4 * 1024 * 1024


class _Checker:
    """The checks of one file; every failure names the file and the field."""

    def __init__(self, where: Any):
        self.where = where

    def fail(self, field: str, rule: str, value: Any) -> InvalidInputError:
        shown = repr(value)
        shown = shown if len(shown) <= 60 else shown[:57] + "..."
        return InvalidInputError(f"{self.where}: {field!r} must be {rule}, got {shown}; not an interval "
                                 "calibration this package wrote (calibrate again)")

    def get(self, doc: dict[str, Any], key: str, field: str) -> Any:
        if key not in doc:
            raise InvalidInputError(f"{self.where}: missing or malformed key {field!r}")
        return doc[key]

    def obj(self, doc: dict[str, Any], key: str, field: str) -> dict[str, Any]:
        value = self.get(doc, key, field)
        if not isinstance(value, dict):
            raise self.fail(field, "a JSON object", value)
        return value

    def text(self, doc: dict[str, Any], key: str, field: str, *, optional: bool = False) -> str | None:
        value = doc.get(key) if optional else self.get(doc, key, field)
        if value is None and optional:
            return None
        if not isinstance(value, str) or not value:
            raise self.fail(field, "a non-empty string", value)
        return value

    def count(self, doc: dict[str, Any], key: str, field: str, low: int = 1) -> int:
        value = self.get(doc, key, field)
        if isinstance(value, bool) or not isinstance(value, int) or value < low:
            raise self.fail(field, f"an integer >= {low}", value)
        return value

    def coverage(self, doc: dict[str, Any], key: str, field: str) -> float:
        value = self.get(doc, key, field)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.0 < value < 1.0:
            raise self.fail(field, "a number in (0, 1)", value)
        return float(value)

    def numbers(self, doc: dict[str, Any], key: str, field: str, length: int) -> np.ndarray:
        value = self.get(doc, key, field)
        if not isinstance(value, list) or len(value) != length \
                or any(isinstance(v, bool) or not isinstance(v, (int, float)) for v in value):
            raise self.fail(field, f"a list of {length} numbers", value)
        out = np.asarray(value, dtype=np.float64)
        if not np.isfinite(out).all():
            raise self.fail(field, f"a list of {length} finite numbers", value)
        return out

    def names(self, doc: dict[str, Any], key: str, field: str) -> list[str]:
        value = self.get(doc, key, field)
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise self.fail(field, "a list of strings", value)
        return value


def _signals(c: _Checker, params: dict[str, Any]) -> list[str]:
    signals = c.names(params, "signals", "params.signals")
    if any(s not in SIGNALS for s in signals) or len(set(signals)) != len(signals):
        raise c.fail("params.signals", f"distinct names from {SIGNALS}", signals)
    return signals


def _check_params(c: _Checker, doc: dict[str, Any]) -> dict[str, Any]:
    params = c.obj(doc, "params", "params")
    c.coverage(params, "coverage", "params.coverage")
    _signals(c, params)
    c.text(params, "spread_method", "params.spread_method")
    c.text(params, "protocol", "params.protocol")
    c.count(params, "seed", "params.seed", low=0)
    c.count(params, "max_fit_pixels", "params.max_fit_pixels", low=10)
    if params.get("weighting", "pixel") not in WEIGHTINGS:
        raise c.fail("params.weighting", f"one of {WEIGHTINGS}", params.get("weighting"))
    return params


def _check_record(c: _Checker, cal: dict[str, Any], params: dict[str, Any], n_pixels: int) -> None:
    """``calibration``: what was calibrated, agreeing with ``params`` and the top-level counts."""
    c.names(cal, "drives", "calibration.drives")
    n_frames = c.count(cal, "n_frames", "calibration.n_frames")
    if c.count(cal, "n_pixels", "calibration.n_pixels") != n_pixels:
        raise c.fail("calibration.n_pixels", f"the top-level n_pixels ({n_pixels})", cal["n_pixels"])
    for key, field in (("coverage", "coverage"), ("signals", "signals"), ("protocol", "protocol"), ("seed", "seed")):
        if c.get(cal, key, f"calibration.{field}") != params[key]:
            raise c.fail(f"calibration.{field}", f"params.{field} ({params[key]!r})", cal[key])
    if cal.get("weighting", params.get("weighting", "pixel")) != params.get("weighting", "pixel"):
        raise c.fail("calibration.weighting", f"params.weighting ({params.get('weighting', 'pixel')!r})",
                     cal.get("weighting"))
    spread = c.text(cal, "spread_method", "calibration.spread_method", optional=True)
    if ("spread" in params["signals"]) != (spread is not None) or spread not in (None, params["spread_method"]):
        raise c.fail("calibration.spread_method", "params.spread_method with the 'spread' signal, else null", spread)
    c.text(cal, "base", "calibration.base")
    folds = cal.get("out_of_fold")
    if folds is None:
        return
    if not isinstance(folds, list) or not folds or not all(isinstance(f, dict) for f in folds):
        raise c.fail("calibration.out_of_fold", "a non-empty list of JSON objects", folds)
    for k, fold in enumerate(folds):
        c.names(fold, "drives", f"calibration.out_of_fold[{k}].drives")
        c.names(fold, "training_drives", f"calibration.out_of_fold[{k}].training_drives")
    for key, total in (("n_frames", n_frames), ("n_pixels", n_pixels)):
        parts = [c.count(f, key, f"calibration.out_of_fold[{k}].{key}") for k, f in enumerate(folds)]
        if sum(parts) != total:
            raise c.fail(f"calibration.out_of_fold[*].{key}", f"counts adding up to calibration.{key} ({total})",
                         parts)


def _check_quantiles(c: _Checker, doc: dict[str, Any], coverage: float, n_pixels: int) -> None:
    """``residual_quantiles`` non-negative and non-decreasing; ``quantile`` positive and between
    the stored quantiles on either side of the coverage."""
    stored = c.numbers(doc, "residual_quantiles", "residual_quantiles", N_LEVELS)
    if stored[0] < 0 or (np.diff(stored) < 0).any():
        raise c.fail("residual_quantiles", "non-negative and non-decreasing (quantiles of |residual| / scale)",
                     doc["residual_quantiles"])
    q = doc.get("quantile")
    if isinstance(q, bool) or not isinstance(q, (int, float)) or not math.isfinite(q) or q <= 0:
        raise c.fail("quantile", "a positive finite number", q)
    if math.ceil((n_pixels + 1) * coverage) > n_pixels:
        raise c.fail("n_pixels", f"enough pixels for a {coverage:g} interval "
                     f"(>= {math.ceil(coverage / (1 - coverage))})", n_pixels)
    # The level of q under either weighting: the frame weighting's is the coverage, the
    # pixel weighting's the rank ceil((n + 1) c) among n.
    rank = (math.ceil((n_pixels + 1) * coverage) - 1) / max(n_pixels - 1, 1)
    levels = [coverage * (N_LEVELS - 1), rank * (N_LEVELS - 1)]
    lo = stored[max(0, math.floor(min(levels)) - 1)]
    hi = max(float(stored[min(N_LEVELS - 1, math.ceil(max(levels)) + 1)]), 1e-6)
    if not lo * (1 - 1e-9) <= q <= hi * (1 + 1e-9):
        raise c.fail("quantile", f"between the stored residual quantiles at the coverage ({lo:.6g} .. {hi:.6g})", q)


def check_calibration(doc: Any, where: Any) -> dict[str, Any]:
    """``doc`` if it is an interval calibration every field of which can mean what it says.

    Raises
    ------
    InvalidInputError
        Naming ``where`` and the first field that breaks its rule (see the module docstring).
    """
    c = _Checker(where)
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise InvalidInputError(f"{where}: 'format' must be {FORMAT!r}")
    c.text(doc, "base", "base")
    c.text(doc, "base_class", "base_class")
    params = _check_params(c, doc)
    coef = c.numbers(doc, "coef", "coef", 1 + len(params["signals"]))
    if (np.abs(coef) > MAX_ABS_COEF).any():
        raise c.fail("coef", f"numbers of at most {MAX_ABS_COEF:g} in size (a scale's log-linear coefficients)",
                     doc["coef"])
    n_pixels = c.count(doc, "n_pixels", "n_pixels")
    _check_record(c, c.obj(doc, "calibration", "calibration"), params, n_pixels)
    _check_quantiles(c, doc, float(params["coverage"]), n_pixels)
    return doc


def read_calibration(path: str | os.PathLike) -> dict[str, Any]:
    """The checked calibration of the file ``path`` (see :func:`check_calibration`).

    Raises
    ------
    InvalidInputError
        Naming the file: not readable, not a regular file (a FIFO is refused at once), too
        large or too deeply nested, not JSON, a NaN or Infinity, or a field that breaks its rule.
    """
    path = Path(path)
    try:
        doc = read_json(path, "interval calibration", limit=MAX_CALIBRATION_BYTES, allow_nan=False)
    except InvalidInputError:
        raise
    except OSError as exc:
        raise InvalidInputError(f"{path}: not a readable interval calibration ({exc})") from None
    return check_calibration(doc, path)


def write_calibration(path: str | os.PathLike, doc: dict[str, Any]) -> Path:
    """Write ``doc`` to ``path`` whole or not at all, never through a link planted there."""
    return write_json(path, doc)
