"""Calling a method the way :func:`inpaintenv.evaluate.evaluate` does: its name, its calling
convention, the checks on its output and the wall clock per frame."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..conventions import as_depth_array, in_depth_range, reconstruction_problem
from ..exceptions import InvalidInputError, InvalidTypeError, MethodOutputError

__all__ = ["Predictor", "method_name", "run_method"]


def method_name(method: Any) -> str:
    """A readable name for ``method``: its ``name`` attribute, function name or class name."""
    name = getattr(method, "name", None)
    if isinstance(name, str) and name:
        return name
    if hasattr(method, "predict"):
        return type(method).__name__
    fn_name = getattr(method, "__name__", None)
    if isinstance(fn_name, str) and fn_name != "<lambda>":
        return fn_name
    return type(method).__name__ if fn_name is None else "lambda"


@dataclass(frozen=True)
class Predictor:
    """How a method is called: its calling convention, its name in errors, the checks on its
    output and the wall clock per frame (what :func:`inpaintenv.evaluate.evaluate` times).

    Parameters
    ----------
    call : callable
        ``(N, H, W) -> (N, H, W)`` when ``batched``, else ``(H, W) -> (H, W)``.
    batched : bool
        Whether ``call`` takes a whole batch.
    name : str
        The method's name in error messages.
    """

    call: Callable[[np.ndarray], Any]
    batched: bool
    name: str

    @classmethod
    def of(cls, method: Any, name: str | None = None) -> Predictor:
        """The predictor of ``method``: objects with ``predict`` are batched (the estimator API);
        plain callables get one ``(H, W)`` frame per call unless they set ``batched = True``.

        Raises
        ------
        InvalidTypeError
            If ``method`` is neither callable nor has a callable ``predict``.
        """
        predict = getattr(method, "predict", None)
        if callable(predict):
            call, batched = predict, True
        elif callable(method):
            call, batched = method, bool(getattr(method, "batched", False))
        else:
            raise InvalidTypeError(
                f"method must be a callable depth -> depth or an object with predict(), got "
                f"{type(method).__name__}"
            )
        return cls(call, batched, name or method_name(method))

    def wrapped(self, wrap: Callable[[Callable[[np.ndarray], Any]], Callable[[np.ndarray], Any]]) -> Predictor:
        """This predictor with its call replaced by ``wrap(call)`` (same convention and name)."""
        return replace(self, call=wrap(self.call))

    def warm_up(self, frame: np.ndarray) -> None:
        """One untimed call on a copy of ``frame`` (a one-frame batch for a batched method); output discarded.

        Errors are left to the timed call that follows, which reports them with the method's name.
        """
        try:
            self.call(frame[None].copy() if self.batched else frame.copy())
        except Exception:  # noqa: BLE001 - the timed call raises it again, checked and named
            pass

    def run(self, x: np.ndarray) -> tuple[np.ndarray, float]:
        """The validated float32 prediction of the checked ``(N, H, W)`` batch ``x`` and ms per frame."""
        if self.batched:
            t0 = time.perf_counter()
            out = self.call(x)
            elapsed = time.perf_counter() - t0
            pred = _check_output(out, x.shape, self.name)
        else:
            pred = np.empty_like(x)
            elapsed = 0.0
            for k in range(len(x)):
                t0 = time.perf_counter()
                # Each frame gets its own copy so a method that writes into its input
                # cannot change what later frames or the metrics see.
                out = self.call(x[k].copy())
                elapsed += time.perf_counter() - t0
                pred[k] = _check_output(out, x.shape[1:], self.name)
        return pred, 1000.0 * elapsed / len(x)


def _check_output(out: Any, expected: tuple[int, ...], name: str) -> np.ndarray:
    """Validate a method's reconstruction; errors name the method."""
    try:
        # The input rule of the whole package: a float array, never an integer (an
        # 8-bit image), masked or sparse one.
        arr = as_depth_array(out, "output")
    except TypeError as exc:
        raise MethodOutputError(f"method {name!r}: {exc}") from None
    except Exception as exc:  # e.g. a ragged list
        raise MethodOutputError(f"method {name!r} returned something that is not an array: {exc}") from exc
    if arr.shape != expected:
        raise MethodOutputError(f"method {name!r} returned shape {arr.shape}, expected {expected}")
    with np.errstate(over="ignore"):  # float64 beyond float32's range: reported as above the bound
        arr32 = arr.astype(np.float32, copy=False)
    # The rule of every scored reconstruction (the env's action check): finite, in [0, DEPTH_LIMIT].
    if not in_depth_range(arr32):
        raise MethodOutputError(f"method {name!r}: output {reconstruction_problem(arr)}")
    return arr32


def run_method(method: Any, x: np.ndarray, name: str | None = None) -> tuple[np.ndarray, float]:
    """Run ``method`` on a corrupted batch the way :func:`evaluate` does.

    Parameters
    ----------
    method : callable or object with ``predict``
    x : numpy.ndarray
        ``(N, H, W)`` float32 input, NaN = fill.
    name : str, optional
        Name used in error messages.

    Returns
    -------
    pred : numpy.ndarray
        Validated ``(N, H, W)`` float32 reconstruction.
    ms : float
        Wall clock of the method per frame, milliseconds.

    Raises
    ------
    ValueError
        If ``x`` is not ``(N, H, W)`` or holds no frames.
    MethodOutputError
        If the method's output is unusable.
    """
    x = np.asarray(x, dtype=np.float32)
    if x.ndim != 3:
        raise InvalidInputError(f"run_method needs an (N, H, W) batch, got shape {x.shape}")
    if len(x) == 0:
        # Otherwise the per-frame time divides by zero.
        raise InvalidInputError(f"run_method got no frames (shape {x.shape})")
    return Predictor.of(method, name).run(x)
