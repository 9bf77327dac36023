"""The data convention shared by the benchmark and every estimator.

Depth maps are float32 arrays in metres, shape ``(H, W)`` or ``(N, H, W)``:

* a positive value is a measurement,
* ``0`` means "no measurement" (LiDAR is semi-dense; sky and far range stay empty),
* ``NaN`` marks the pixels a method must fill (the simulated occlusion).

Ground truth never contains NaN; method inputs carry NaN exactly inside the holes.
Depth never exceeds :data:`DEPTH_LIMIT` (65535 / 256 m), the most KITTI's 16-bit PNG
encoding can hold, so raw PNG values (metres x 256) passed by mistake are refused.

One input rule holds everywhere depth enters (method inputs, ground truth, a method's
output, an environment action; :func:`as_depth_array`): depth is a plain floating-point
NumPy array (or anything ``np.asarray`` turns into one). Integer arrays are refused -- an
8-bit image, raw 16-bit PNG codes or millimetres, never metres -- as are masked arrays
(the mask would be dropped silently) and scipy.sparse matrices. A positive depth below
:data:`MIN_DEPTH` (1 mm; e.g. ``1e-30``, a subnormal) is refused in inputs and ground
truth: no sensor measures it, and methods that invert depth turn it into ~inf.
Validated depth comes back C-contiguous, so a method sees the same memory layout
whatever the caller passed (same values in, same bits out).

A 3-D array is a batch of frames, each at least :data:`MIN_FRAME_SIDE` pixels high and wide:
an image ``(H, W, 3)`` or ``(H, W, 1)`` would otherwise be read as ``H`` frames of width 3
or 1 and scored as such. A single 2-D frame may be any size (it has no axis to misread).

Seeds, frame indices and counts are plain non-negative integers
(:func:`check_int`, :func:`check_seed`, :func:`check_seeds`): a float, a bool or a
string is refused rather than truncated, so ``seeds="12"`` never becomes ``[1, 2]``.
"""

from __future__ import annotations

import math
import operator
from collections import Counter
from collections.abc import Iterable
from typing import Any

import numpy as np

from .exceptions import InvalidInputError, InvalidTypeError
from .files.limits import MAX_FRAME_PIXELS

__all__ = [
    "DEFAULT_MAX_DEPTH", "DEPTH_LIMIT", "MAX_FRAME_PIXELS", "MIN_DEPTH", "MIN_FRAME_SIDE", "as_depth_array", "check_depth",
    "check_frame_shape", "check_int", "check_mask", "check_max_depth",
    "check_seed", "check_seeds", "corrupt", "in_depth_range", "is_int", "is_real_number", "reconstruction_problem",
]

#: Fixed range used to normalise depth and to compute PSNR (the study's 80 m).
DEFAULT_MAX_DEPTH: float = 80.0
#: The largest depth KITTI's 16-bit PNG encoding can hold (65535 / 256 = 255.996 m).
DEPTH_LIMIT: float = 65535.0 / 256.0
#: Smallest height and width of a frame in an ``(N, H, W)`` batch. A smaller axis is far
#: more likely a channel axis (colour 3 or 4, grey 1) than a frame that narrow; 8 px is
#: below any depth sensor's image and above any channel count.
MIN_FRAME_SIDE: int = 8
#: Smallest positive depth accepted in inputs and ground truth (1 mm). KITTI's PNG step is
#: 1/256 m and LiDAR sees nothing nearer than decimetres, so a smaller positive value is
#: a unit mistake or numerical debris (1e-30, subnormals), not a measurement.
MIN_DEPTH: float = 1e-3


def _is_sparse(value: object) -> bool:
    """True for scipy.sparse matrices and arrays (without importing scipy)."""
    return type(value).__module__.startswith("scipy.sparse")


def as_depth_array(value: object, name: str = "depth") -> np.ndarray:
    """``value`` as a floating-point NumPy array, or one clear ``TypeError``.

    The one dtype rule for depth everywhere (inputs, ground truth, outputs, actions):
    values and shape are not checked here (see :func:`check_depth`).

    Parameters
    ----------
    value : array-like
        Depth in metres.
    name : str
        Name used in error messages.

    Returns
    -------
    numpy.ndarray
        ``np.asarray(value)``, of a floating dtype (not converted).

    Raises
    ------
    TypeError
        For a masked array, a scipy.sparse matrix, or an array that is not floating
        point (integer, boolean, complex, object, strings).
    """
    if isinstance(value, np.ma.MaskedArray):
        # np.asarray would silently drop the mask: the masked pixels could mean "fill"
        # or "no data", so the caller has to say which.
        raise InvalidTypeError(
            f"{name} is a numpy masked array; pass a plain array with 0 for no data "
            "(and NaN for pixels to fill), e.g. m.filled(0)"
        )
    if _is_sparse(value):
        raise InvalidTypeError(
            f"{name} is a scipy.sparse {type(value).__name__}; depth maps are dense arrays: pass "
            f"{name}.toarray() (0 = no measurement)"
        )
    arr = np.asarray(value)
    if arr.dtype == np.bool_:
        raise InvalidTypeError(f"{name} must be depth in metres, got a boolean array (dtype bool)")
    if np.issubdtype(arr.dtype, np.integer):
        # Integer depth is never metres: an 8-bit image, raw KITTI PNG codes (metres x 256)
        # or millimetres. Refused everywhere, as the environment refuses an integer action.
        raise InvalidTypeError(
            f"{name} has integer dtype {arr.dtype}; depth is floating-point metres (an 8-bit image? "
            "raw KITTI PNG values? divide by 256: x / 256.0)"
        )
    if not np.issubdtype(arr.dtype, np.floating):
        raise InvalidTypeError(f"{name} must be a real numeric (floating-point) array of metres, got dtype {arr.dtype}")
    return arr


def check_depth(
    depth: object,
    *,
    name: str = "depth",
    allow_nan: bool = False,
    ndim: tuple[int, ...] = (2, 3),
) -> np.ndarray:
    """Validate a depth map and return it as a float32 array (no copy if possible).

    Parameters
    ----------
    depth : array-like
        Depth in metres, ``(H, W)`` or ``(N, H, W)``.
    name : str
        Name used in error messages.
    allow_nan : bool
        Whether NaN (pixels to fill) may appear.
    ndim : tuple of int
        Accepted numbers of dimensions.

    Returns
    -------
    numpy.ndarray
        C-contiguous float32 view or copy of ``depth`` (the input itself when it
        already is one).

    Raises
    ------
    TypeError
        If ``depth`` is not a floating-point array (see :func:`as_depth_array`: integer,
        boolean, complex, object), a masked array or a scipy.sparse matrix.
    ValueError
        On a wrong number of dimensions, a 3-D array that cannot be a batch of frames
        (a last axis of size 1, 3 or 4 -- a channel axis -- or frames smaller than
        :data:`MIN_FRAME_SIDE` pixels), an empty array, infinite values,
        NaN where not allowed, negative depth, depth above :data:`DEPTH_LIMIT` (also a
        float64 value beyond float32's range), or positive depth below :data:`MIN_DEPTH`.
    """
    arr = as_depth_array(depth, name)
    if arr.ndim not in ndim:
        want = " or ".join(f"{d}-D" for d in ndim)
        raise InvalidInputError(f"{name} must be {want} (H, W) / (N, H, W), got shape {arr.shape}")
    if arr.ndim == 3:
        _check_batch_shape(arr.shape, name)
    if arr.size == 0:
        raise InvalidInputError(f"{name} is empty (shape {arr.shape})")
    # A float64 value beyond float32's range becomes inf here; the range check below
    # reports the original value, not the inf.
    with np.errstate(over="ignore"):
        # C order: a method sees one memory layout whatever the caller passed, so the
        # same values give the same bits (Fortran-ordered or strided input included).
        out = np.ascontiguousarray(arr, dtype=np.float32)
    # A float64 input is checked for tiny depth as given: 1e-50 is 0 in float32.
    if in_depth_range(out) and not _below_min_depth(out) and (arr.dtype == np.float32 or not _below_min_depth(arr)):
        return out
    _explain_bad_depth(arr, name, allow_nan)
    return out


def _below_min_depth(arr: np.ndarray) -> int:
    """Number of pixels of the non-negative float array ``arr`` in ``(0, MIN_DEPTH)``."""
    # Two counts instead of a masked minimum (~20x faster on a KITTI frame): below
    # MIN_DEPTH and non-negative means 0 (no measurement) or a too-small depth.
    return int(np.count_nonzero(arr < MIN_DEPTH) - np.count_nonzero(arr == 0))


def _explain_bad_depth(arr: np.ndarray, name: str, allow_nan: bool) -> None:
    """Raise the ValueError saying what is wrong with ``arr`` (its original dtype), if anything."""
    if np.isinf(arr).any():
        raise InvalidInputError(f"{name} contains infinite values; use 0 for 'no measurement'")
    if not allow_nan and np.isnan(arr).any():
        raise InvalidInputError(f"{name} contains NaN; NaN marks pixels to fill and is not allowed here "
                                "(use 0 for 'no measurement')")
    # NaN compares False, so these only look at real values.
    if (arr < 0).any():
        raise InvalidInputError(f"{name} contains negative depth (min {np.nanmin(arr):.3g} m)")
    if (arr > DEPTH_LIMIT).any():
        top = float(np.nanmax(arr))
        hint = ": raw PNG values? divide by 256" if top <= 65535 else ""
        raise InvalidInputError(
            f"{name} has depth up to {top:.4g} m, above {DEPTH_LIMIT:.3f} m, the most a "
            f"KITTI 16-bit PNG can hold{hint}"
        )
    tiny = (arr > 0) & (arr < MIN_DEPTH)
    if tiny.any():
        raise InvalidInputError(
            f"{name} has {int(tiny.sum())} pixels of positive depth below {MIN_DEPTH:g} m (smallest "
            f"{float(arr[tiny].min()):.3g} m); no sensor measures that: use 0 for 'no measurement'"
        )


def _check_batch_shape(shape: tuple[int, ...], name: str) -> None:
    """Refuse an ``(N, H, W)`` shape whose frames cannot be depth maps (see :data:`MIN_FRAME_SIDE`)."""
    if shape[0] == 0 or shape[1] == 0 or shape[2] == 0:
        return  # reported as empty by the caller
    # A channel axis only where the (H, W, C) reading is an image; (1, 1, 1) is a 1x1 frame, too small either way.
    if shape[-1] in (1, 3, 4) and min(shape[:2]) >= MIN_FRAME_SIDE:
        kind = "a channel axis" if shape[-1] == 1 else "colour channels (an RGB/RGBA image)"
        raise InvalidInputError(
            f"{name} has shape {shape}: a trailing size-{shape[-1]} axis looks like {kind}; pass (H, W) "
            f"or (N, H, W) depth, not {shape[0]} frames of width {shape[-1]}"
        )
    if min(shape[1:]) < MIN_FRAME_SIDE:
        raise InvalidInputError(
            f"{name} has shape {shape}: too small: read as {shape[0]} frames of {shape[1]}x{shape[2]} pixels, but a "
            f"depth frame in an (N, H, W) batch is at least {MIN_FRAME_SIDE}x{MIN_FRAME_SIDE} (MIN_FRAME_SIDE)"
        )


def in_depth_range(arr: np.ndarray) -> bool:
    """True if every value of the float array ``arr`` is in ``[0, DEPTH_LIMIT]``.

    Two reductions (min, max) decide it, instead of one full-frame pass (and temporary)
    per refusal reason; callers explain a False themselves. NaN propagates through
    ``min``/``max`` and fails both comparisons, ``-inf``/``inf`` fail one, so a False
    covers NaN, inf, negative depth and depth above :data:`DEPTH_LIMIT`.
    """
    return bool(arr.min() >= 0 and arr.max() <= DEPTH_LIMIT)


def reconstruction_problem(values: np.ndarray) -> str | None:
    """What keeps the float array ``values`` from being a reconstruction, or None.

    The one rule for what a method may return, wherever it is scored (an environment
    action, :func:`inpaintenv.evaluate.evaluate`'s method output, the prediction of
    :func:`inpaintenv.metrics.frame_metrics`): every value, stored as float32, is a
    depth in ``[0, DEPTH_LIMIT]`` -- finite, non-negative and at most what a KITTI
    16-bit PNG can hold (255.996 m), the bound of the environment's action space. A
    float64 value beyond float32's range counts as above the bound, not as inf.

    Parameters
    ----------
    values : numpy.ndarray
        A floating-point array (:func:`as_depth_array`), any shape.

    Returns
    -------
    str or None
        None when every value is allowed (two reductions, :func:`in_depth_range`); else a
        phrase starting with "has", for the caller to prefix ("action has ...").
    """
    with np.errstate(over="ignore"):
        stored = values.astype(np.float32, copy=False)
    if stored.size == 0 or in_depth_range(stored):
        return None
    n_bad = int(np.count_nonzero(~np.isfinite(values)))
    if n_bad:
        return f"has {n_bad} pixel{'s' * (n_bad != 1)} NaN or inf; every pixel must be filled with a depth in metres"
    if (values < 0).any():
        return f"has negative depth (min {float(values.min()):.3g} m)"
    return (f"has depth up to {float(values.max()):.6g} m, above the bound {DEPTH_LIMIT:.3f} m, the most a KITTI "
            "16-bit PNG can hold (DEPTH_LIMIT)")


def is_int(value: object) -> bool:
    """True for Python and NumPy integers (and 0-d integer arrays), never for bool or float: what an
    integer parameter may be, here and in the estimators' parameter tables."""
    if isinstance(value, (bool, np.bool_)):
        return False
    try:
        operator.index(value)  # type: ignore[arg-type]
    except TypeError:
        return False
    return True


def is_real_number(value: object) -> bool:
    """True for Python and NumPy integers and floats, never for bool, str or None.

    For numeric parameters that must be refused rather than coerced (``"80"``, ``True``).
    """
    return not isinstance(value, (bool, np.bool_)) and isinstance(value, (int, float, np.integer, np.floating))


def _show(value: object) -> str:
    """``value`` for an error message: plain numbers as Python prints them, else repr."""
    if isinstance(value, np.generic):
        value = value.item()
    text = repr(value)
    # A long index list would otherwise fill the terminal; the head is enough to recognise it.
    return text if len(text) <= 200 else f"{text[:160]}... ({len(text)} characters)"


def check_int(value: object, name: str, *, minimum: int = 0, upper: int | None = None) -> int:
    """Validate one integer parameter (a count, an index) and return it as a Python int.

    Parameters
    ----------
    value : object
        The parameter. Python and NumPy integers are accepted; bool, float (even
        ``2.0``) and strings are refused instead of being truncated or parsed.
    name : str
        Parameter name used in the error message.
    minimum : int
        Smallest allowed value.
    upper : int, optional
        Exclusive upper bound.

    Returns
    -------
    int

    Raises
    ------
    TypeError
        If ``value`` is not an integer.
    ValueError
        If it is out of range.
    """
    if not is_int(value):
        raise InvalidTypeError(f"{name} must be an integer, got {_show(value)} ({type(value).__name__})")
    v = operator.index(value)  # type: ignore[arg-type]
    if v < minimum or (upper is not None and v >= upper):
        want = f">= {minimum}" if upper is None else f"in {minimum}..{upper - 1}"
        raise InvalidInputError(f"{name} must be {want}, got {v}")
    return v


def check_frame_shape(value: object, name: str = "frame_shape", *, minimum: int = MIN_FRAME_SIDE) -> tuple[int, int]:
    """Validate a frame size ``(H, W)`` and return it as two Python ints.

    Parameters
    ----------
    value : object
        Two integers (tuple, list, 1-D array); floats, bools and strings are refused.
    name, minimum : str, int
        Parameter name for messages (``"--frame-shape"``); smallest height and width.

    Raises
    ------
    TypeError
        If ``value`` is not two integers.
    ValueError
        If a side is below ``minimum`` or the frame has more than :data:`MAX_FRAME_PIXELS` pixels.
    """
    if isinstance(value, (str, bytes)) or not isinstance(value, (tuple, list, np.ndarray)) or len(value) != 2 \
            or not all(is_int(v) for v in value):
        raise InvalidTypeError(f"{name} must be two integers (H, W), got {_show(value)}")
    h, w = (operator.index(v) for v in value)  # type: ignore[arg-type]
    if h < minimum or w < minimum:
        raise InvalidInputError(f"{name} must be at least {minimum} x {minimum} (H x W), got {h} x {w}")
    if h * w > MAX_FRAME_PIXELS:
        raise InvalidInputError(f"{name} {h} x {w} is {h * w:,} pixels, more than the {MAX_FRAME_PIXELS:,} a frame may have "
                         "(MAX_FRAME_PIXELS)")
    return h, w


def check_seed(value: object, name: str = "seed") -> int:
    """Validate one seed: a non-negative integer (not bool, float or str).

    Raises
    ------
    TypeError
        If ``value`` is not an integer (the message names ``name``).
    ValueError
        If it is negative.
    """
    if not is_int(value) or operator.index(value) < 0:  # type: ignore[arg-type]
        raise (InvalidInputError if is_int(value) else InvalidTypeError)(
            f"{name} must be a non-negative integer, got {_show(value)}"
        )
    return operator.index(value)  # type: ignore[arg-type]


def check_seeds(
    values: object,
    name: str = "seeds",
    *,
    upper: int | None = None,
    distinct: bool = True,
    allow_empty: bool = False,
) -> list[int]:
    """Validate a list of seeds or frame indices and return it as Python ints.

    Parameters
    ----------
    values : int or iterable of int
        One integer, or a non-empty sequence (list, tuple, range, 1-D integer array) of
        non-negative integers. A string is refused, never iterated character by character.
    name : str
        Parameter name used in error messages.
    upper : int, optional
        Exclusive upper bound (e.g. the number of frames for indices).
    distinct : bool
        Refuse repeated values (a repeated seed or index would be scored twice and
        weigh double in every mean).
    allow_empty : bool
        Accept an empty sequence (returns ``[]``).

    Returns
    -------
    list of int

    Raises
    ------
    TypeError
        If ``values`` or an entry is not an integer.
    ValueError
        If it is empty (unless ``allow_empty``), an entry is negative or ``>= upper``, or (with ``distinct``)
        a value repeats.
    """
    kind = "distinct non-negative integers" if distinct else "non-negative integers"
    if is_int(values):
        items: list[Any] = [values]
    elif isinstance(values, (str, bytes)) or not isinstance(values, Iterable) or (
        isinstance(values, np.ndarray) and values.ndim != 1
    ):
        raise InvalidTypeError(f"{name} must be {kind}, got {_show(values)}")
    else:
        items = list(values)
    if not items and not allow_empty:
        raise InvalidInputError(f"{name} is empty")
    bad = [v for v in items if not is_int(v)]
    if bad:
        raise InvalidTypeError(f"{name} must be {kind}, got {_show(values)}")
    out = [operator.index(v) for v in items]
    if any(v < 0 for v in out):
        raise InvalidInputError(f"{name} must be {kind}, got {_show(values) if is_int(values) else _show(out)}")
    if upper is not None and any(v >= upper for v in out):
        outside = [v for v in out if v >= upper]
        raise InvalidInputError(f"{name} {outside[:5]} are outside 0..{upper - 1}")
    if distinct and len(set(out)) != len(out):
        dup = sorted(v for v, n in Counter(out).items() if n > 1)  # linear: index lists can be long
        raise InvalidInputError(f"{name} must be {kind}, got {_show(out)} ({_show(dup)} repeated)")
    return out


def check_max_depth(value: object, name: str = "max_depth") -> float:
    """Validate a depth range (PSNR range, colour-scale top): a finite positive number.

    Raises
    ------
    TypeError
        If ``value`` is not a real number (a string, None, bool).
    ValueError
        If it is NaN, infinite, zero or negative.
    """
    msg = f"{name} must be a finite positive number of metres, got {_show(value)}"
    if not is_real_number(value):
        raise InvalidTypeError(msg)
    v = float(value)
    if not math.isfinite(v) or v <= 0:
        raise InvalidInputError(msg)
    return v


def check_mask(mask: object, shape: tuple[int, ...], *, name: str = "hole") -> np.ndarray:
    """Validate a boolean (or 0/1) occlusion mask of the given shape and return it as bool."""
    arr = np.asarray(mask)
    if arr.shape != tuple(shape):
        raise InvalidInputError(f"{name} mask has shape {arr.shape}, expected {tuple(shape)}")
    if arr.dtype != np.bool_:
        if not (np.issubdtype(arr.dtype, np.integer) or np.issubdtype(arr.dtype, np.floating)):
            raise InvalidTypeError(f"{name} mask must be boolean or 0/1, got dtype {arr.dtype}")
        if not np.isin(arr, (0, 1)).all():
            raise InvalidInputError(f"{name} mask must contain only 0 and 1")
        arr = arr.astype(bool)
    return arr


def corrupt(depth: np.ndarray, hole: np.ndarray) -> np.ndarray:
    """Return a float32 copy of ``depth`` with NaN inside ``hole`` (the method input).

    Parameters
    ----------
    depth : numpy.ndarray
        Ground truth, ``(H, W)`` or ``(N, H, W)``, metres, 0 = no measurement.
    hole : numpy.ndarray
        Boolean mask of the same shape, True where the occlusion is.

    Returns
    -------
    numpy.ndarray
        float32 array of ``depth``'s shape.
    """
    depth = check_depth(depth, name="ground truth")
    hole = check_mask(hole, depth.shape)
    out = np.array(depth, dtype=np.float32, copy=True)
    out[hole] = np.nan
    return out
