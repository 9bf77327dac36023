"""The method of a ``fill`` run: made from a name, a checkpoint or an object, and called on a batch."""

from __future__ import annotations

import os
from types import SimpleNamespace
from typing import Any

import numpy as np

from ..conventions import DEPTH_LIMIT, as_depth_array, check_depth
from ..data.inputs import INPUT_KINDS
from ..exceptions import InvalidInputError, InvalidTypeError, MethodOutputError
from ..files import open_regular
from ..methods.calls import method_name, run_method
from ..methods.intervals import IntervalSource

__all__ = [
    "INPUT_CHOICES", "check_input_choice", "fill_batch", "fill_depth", "interval_method", "resolve_method", "router", "shipped_interval_name",
]

#: Values of ``input``: each frame's kind told from its measured density, or every frame of one kind.
INPUT_CHOICES = ("auto", *INPUT_KINDS)


def fill_depth(method: Any, depth: np.ndarray, fill: np.ndarray | None = None) -> np.ndarray:
    """Fill one depth map in memory, as :func:`~inpaintenv.filling.fill` fills each file.

    Parameters
    ----------
    method : str, estimator or callable
        A registry name, or anything :func:`inpaintenv.evaluate.evaluate` scores (``predict``
        of NaN = fill).
    depth : numpy.ndarray
        ``(H, W)`` float metres, 0 = no measurement, NaN = fill.
    fill : numpy.ndarray of bool, optional
        Further pixels to fill (a hole mask).

    Returns
    -------
    numpy.ndarray
        ``depth``'s dtype and shape: measured pixels outside the fill bit-identical, pixels
        without a measurement outside it still 0, filled pixels positive and finite.

    Raises
    ------
    InvalidTypeError
        ``depth`` is not a floating-point array (integer, boolean, object, strings, None),
        or ``fill`` is not an array of booleans or numbers.
    InvalidInputError
        ``depth`` is not 2-D or holds values no depth map has (negative, infinite, above the
        PNG limit), or ``fill`` does not have ``depth``'s shape.
    """
    depth = as_depth_array(depth, "depth")
    check_depth(depth, name="depth", allow_nan=True, ndim=(2,))
    mask = np.isnan(depth) if fill is None else _check_fill(fill, depth.shape) | np.isnan(depth)
    return fill_batch(*resolve_method(method, None, None), [depth], [mask])[0]


def _check_fill(fill: Any, shape: tuple[int, ...]) -> np.ndarray:
    """The pixels to fill as booleans (nonzero = fill), or one clear error."""
    mask = np.asarray(fill)
    if not (mask.dtype == np.bool_ or np.issubdtype(mask.dtype, np.integer) or np.issubdtype(mask.dtype, np.floating)):
        raise InvalidTypeError(f"fill (the pixels to fill) must be an array of booleans or numbers (nonzero = fill), "
                               f"got dtype {mask.dtype}")
    if mask.shape != shape:
        raise InvalidInputError(f"fill (the pixels to fill) must have the depth's shape {shape}, got {mask.shape}")
    if np.issubdtype(mask.dtype, np.floating) and not np.isfinite(mask).all():
        raise InvalidInputError("fill (the pixels to fill) holds NaN or infinite values; give booleans (True = fill)")
    return mask.astype(bool, copy=False)


def fill_batch(method: Any, name: str, depths: list[np.ndarray], fills: list[np.ndarray], *,
               copy: bool = True, interval: IntervalSource | None = None) -> list[np.ndarray]:
    """Fill same-sized maps in one ``predict`` call.

    In place unless ``copy``; frames with nothing to fill come back as they are. With
    ``interval``, each filled map is followed by its ``low`` and ``high`` (the list holds
    ``3 · len(depths)`` arrays, in the depth's dtype).

    Raises
    ------
    MethodOutputError
        If the method leaves a pixel to fill at 0 m, or its output is unusable.
    """
    todo = [k for k, f in enumerate(fills) if f.any()]
    out = [d.copy() for d in depths] if copy else list(depths)
    if not todo:
        return [a for d in out for a in (d, d, d)] if interval is not None else out
    x = np.stack([depths[k] for k in todo]).astype(np.float32, copy=False)
    hole = np.stack([fills[k] for k in todo])
    x[hole] = np.nan
    # An object with predict is called batched; the interval source may swap in predict(X, return_std=True).
    caller = SimpleNamespace(predict=interval.wrap(method.predict)) if interval is not None else method
    pred, _ = run_method(caller, x, name)
    bounds = interval.bounds(x, pred, hole) if interval is not None else None
    for k, p in zip(todo, pred):
        unfilled = np.count_nonzero(fills[k] & (p <= 0))
        if unfilled:
            raise MethodOutputError(_unfilled_message(name, unfilled, fills[k], depths[k]))
        np.copyto(out[k], p, where=fills[k], casting="same_kind")
    if bounds is None:
        return out
    lows, highs = [d.copy() for d in out], [d.copy() for d in out]
    # Capped at the most a depth file holds, in float64: a huge bound would overflow the depth's float32.
    low, high = (np.minimum(b, DEPTH_LIMIT) for b in bounds)
    for j, k in enumerate(todo):  # measured pixels: low = high = the measurement; unmeasured, unfilled: 0
        np.copyto(lows[k], low[j], where=fills[k], casting="same_kind")
        np.copyto(highs[k], high[j], where=fills[k], casting="same_kind")
    return [a for triple in zip(out, lows, highs) for a in triple]


def _unfilled_message(name: str, unfilled: int, fill: np.ndarray, depth: np.ndarray) -> str:
    """Why a frame failed with pixels left at 0 m, and what to try: never the method that just failed."""
    head = f"method {name!r} left {unfilled} of the {np.count_nonzero(fill)} pixels to fill at 0 m"
    if not np.count_nonzero((depth > 0) & ~fill):
        return f"{head}: the frame has no measurement outside the pixels to fill, so nothing to fill them from"
    other = "harmonic" if name.split("+")[0].split("-")[0] == "nearest" else "nearest"
    return (f"{head} (no measurement near them?); try a method that reaches every pixel from the measurements, "
            f"e.g. --method {other}")


def resolve_method(method: Any, checkpoint: Any, n_jobs: int | None, input: str | None = None) -> tuple[Any, str]:
    """The method of a run and its name: a registry name, a checkpoint folder, or an estimator as given.

    ``input`` (one of :data:`INPUT_CHOICES`, checked by the caller: :func:`check_input_choice`) is set
    as the ``input`` parameter of a method that routes by input kind (``pretrained``); any other method
    refuses it.
    """
    from ..methods.registry import canonical_name
    from ..methods.registry import make_method as make

    name = str(method) if isinstance(method, str) else method_name(method)
    if checkpoint is not None:
        method, name = make("checkpoint", path=checkpoint), str(checkpoint)
    elif isinstance(method, str):
        method = make(canonical_name(method))
    if n_jobs is not None:
        params = method.get_params() if hasattr(method, "get_params") else {}
        if "n_jobs" not in params:
            raise InvalidInputError(f"--jobs applies to methods that take n_jobs (the classical ones); "
                                    f"{method_name(method)} does not")
        method.set_params(n_jobs=n_jobs)
    if input is not None:
        _set_input(method, name, input)
    return method, name


def check_input_choice(input: Any) -> str | None:
    """``input`` if it is None or one of :data:`INPUT_CHOICES`, else one line naming the choices.

    Checked once, where ``fill`` is called; :func:`resolve_method` takes it as it is.
    """
    if input is not None and input not in INPUT_CHOICES:
        raise InvalidInputError(f"input (--input) must be one of {', '.join(INPUT_CHOICES)}, got {input!r}")
    return input


def _set_input(method: Any, name: str, input: str) -> None:
    """Set the checked ``input`` on ``method`` (or the estimator an interval wrapper holds), or refuse in one line."""
    for target in (method, getattr(method, "estimator", None)):
        params = target.get_params(deep=False) if hasattr(target, "get_params") else {}
        if "input" in params:
            target.set_params(input=input)
            return
    raise InvalidInputError(f"--input applies to a method that fills each input kind its own way (pretrained); "
                            f"{name} fills every input alike: leave --input out")


def router(method: Any) -> Any:
    """The estimator that routes each frame by its input kind (has ``routed_to_`` after a predict): ``method``
    itself, or the estimator an interval wrapper holds; None for any other method."""
    for target in (method, getattr(method, "estimator", None)):
        if target is not None and hasattr(target, "scan_name") and hasattr(target, "map_name") \
                and callable(getattr(target, "choose", None)):
            return target
    return None


def shipped_interval_name(method: Any) -> Any:
    """``<name>-intervals`` for a registry name whose release ships an interval calibration; else ``method``."""
    from ..methods.learned import DEFAULT_RELEASE
    from ..methods.registry import available_aliases, available_methods, canonical_name, get_spec

    if isinstance(method, str) and not method.count(":"):
        canon = canonical_name(method)
        spec = get_spec(canon)
        names = [f"{canon}-intervals"]
        if spec.cls == "load_release":  # any name of a release: blend-pretrained-mixed is kitti-mixed-v1
            names.append(f"{spec.kwargs.get('name', DEFAULT_RELEASE)}-intervals")
        for name in names:
            if name in available_methods() or name in available_aliases():
                return name
    return method


def interval_method(method: Any, name: str, intervals: str | os.PathLike | None,
                    coverage: float) -> tuple[Any, str, IntervalSource]:
    """The method of a ``confidence`` run, its name and its interval source.

    ``intervals`` (a saved calibration) wraps ``method``; a method with its own interval is
    used as it is.

    Raises
    ------
    InvalidInputError
        If the method has no interval and no calibration is given.
    """
    from ..methods.intervals import interval_source
    from ..methods.registry import available_methods
    from ..methods.registry import make_method as make

    if intervals is not None:
        os.close(open_regular(intervals, "--intervals calibration file"))  # a FIFO is named, never waited on
        method = make("intervals", path=intervals, estimator=method)
        name = f"{name}+intervals"
    source = interval_source(method, coverage, name)
    if source is None:
        shipped = [m[: -len("-intervals")] for m in available_methods() if m.endswith("-intervals")]
        ships = f", or a method shipped with one ({', '.join(shipped)})" if shipped else ""
        raise InvalidInputError(
            f"--confidence needs a per-pixel interval and method {name!r} has none: give --intervals CAL.json (a "
            f"ConformalIntervalInpainter calibration of this method, saved with .save){ships}")
    return method, name, source
