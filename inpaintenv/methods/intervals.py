"""Asking a method for a per-pixel interval the way :func:`inpaintenv.evaluate.evaluate` does.

The protocol, scikit-learn's way, tried in this order:

1. ``method.predict_interval(X, coverage=c) -> (low, high)``: the method names its own
   interval of nominal coverage ``c`` for the ``(N, H, W)`` batch ``X`` (metres). The
   prediction still comes from the timed call of ``predict`` (or of the callable); the
   interval call is not timed. A ``predict_interval`` that takes ``prediction=`` is given
   that prediction, so it need not predict again.
2. ``method.predict(X, return_std=True) -> (pred, std)`` (as ``GaussianProcessRegressor``
   and ``BayesianRidge`` return it), when ``predict`` takes a ``return_std`` argument:
   this one call is timed and gives both; the interval is the normal one of
   :func:`inpaintenv.metrics.interval_from_std`.

A method with neither gives no interval: its rows simply lack the interval columns.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from typing import Any

import numpy as np

from ..exceptions import InvalidInputError, InvalidTypeError, MethodOutputError
from ..metrics import Coverage, check_interval, interval_from_std

__all__ = ["IntervalSource", "interval_source"]


def _takes(function: Callable, argument: str) -> bool:
    try:
        return argument in inspect.signature(function).parameters
    except (TypeError, ValueError):  # builtins without a signature
        return False


class IntervalSource:
    """How one method gives its interval, for one evaluation at ``coverage`` (checked where it entered).

    ``wrap(call)`` gives the prediction call to time (it keeps ``std`` aside for a
    ``return_std`` method); ``bounds(x, pred, hole)`` gives the checked ``(low, high)``.
    """

    def __init__(self, method: Any, coverage: Coverage, name: str, kind: str) -> None:
        self.method, self.coverage, self.name, self.kind = method, coverage, name, kind
        self._std: Any = None
        self.at_levels: dict[float, tuple[np.ndarray, np.ndarray]] = {}

    def wrap(self, call: Callable) -> Callable:
        """The prediction call: ``call`` itself, or ``predict(X, return_std=True)`` keeping ``std``."""
        if self.kind != "std":
            return call

        def predict_with_std(x: np.ndarray) -> Any:
            out = self.method.predict(x, return_std=True)
            if not (isinstance(out, tuple) and len(out) == 2):
                raise MethodOutputError(f"method {self.name!r}: predict(X, return_std=True) must return (pred, std), "
                                        f"got {type(out).__name__}")
            self._std = out[1]
            return out[0]

        return predict_with_std

    def bounds(self, x: np.ndarray, pred: np.ndarray, hole: np.ndarray,
               levels: tuple[float, ...] = ()) -> tuple[np.ndarray, np.ndarray]:
        """``(low, high)`` of the batch ``x`` whose checked prediction is ``pred``.

        With ``levels`` (nominal coverages), the interval of each is asked too and kept in
        :attr:`at_levels` (``{level: (low, high)}``), checked alike: the reliability diagram's.

        Raises
        ------
        MethodOutputError
            Naming the method, when the interval is not a pair of arrays of the batch's
            shape, is NaN/inf, negative, inverted or does not hold the prediction in the hole.
        """
        try:
            std, self._std = (self._std, None) if self.kind == "std" else (None, None)
            # The levels first: a method sees the coverage asked last (as without levels).
            at = {c: self._bounds(x, pred, hole, c, std) for c in levels if c != self.coverage}
            low, high = self._bounds(x, pred, hole, self.coverage, std)
            self.at_levels = {c: at.get(c, (low, high)) for c in levels}
            return low, high
        except (InvalidInputError, InvalidTypeError) as exc:  # the interval's checks; a bug in the method shows as such
            raise MethodOutputError(f"method {self.name!r}: {exc}") from None

    def _bounds(self, x: np.ndarray, pred: np.ndarray, hole: np.ndarray, coverage: float,
                std: Any) -> tuple[np.ndarray, np.ndarray]:
        if self.kind == "std":
            low, high = interval_from_std(pred, std, coverage)
        else:
            given = {"prediction": pred} if _takes(self.method.predict_interval, "prediction") else {}
            out = self.method.predict_interval(x, coverage=coverage, **given)
            if not (isinstance(out, tuple) and len(out) == 2):
                raise InvalidInputError(f"predict_interval must return (low, high), got {type(out).__name__}")
            low, high = out
        return check_interval(pred, low, high, hole)


def interval_source(method: Any, coverage: Coverage | None, name: str) -> IntervalSource | None:
    """The :class:`IntervalSource` of ``method`` at ``coverage``; None without one (or without ``coverage``)."""
    if coverage is None:
        return None
    if callable(getattr(method, "predict_interval", None)):
        return IntervalSource(method, coverage, name, "interval")
    predict = getattr(method, "predict", None)
    if callable(predict) and _takes(predict, "return_std"):
        return IntervalSource(method, coverage, name, "std")
    return None
