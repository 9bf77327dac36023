"""The data convention shared by the benchmark and every estimator.

Depth maps are float32 arrays in metres, shape ``(H, W)`` or ``(N, H, W)``:

* a positive value is a measurement,
* ``0`` means "no measurement" (LiDAR is semi-dense; sky and far range stay empty),
* ``NaN`` marks the pixels a method must fill (the simulated occlusion).

Ground truth never contains NaN; method inputs carry NaN exactly inside the holes.
"""

from __future__ import annotations

import numpy as np

__all__ = ["DEFAULT_MAX_DEPTH", "check_depth", "check_mask", "corrupt"]

#: Fixed range used to normalise depth and to compute PSNR (the study's 80 m).
DEFAULT_MAX_DEPTH: float = 80.0


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
        float32 view or copy of ``depth``.

    Raises
    ------
    TypeError
        If ``depth`` is not a real-valued numeric array.
    ValueError
        On a wrong number of dimensions, an empty array, infinite values, NaN where
        not allowed, or negative depth.
    """
    arr = np.asarray(depth)
    if arr.dtype == np.bool_:
        raise TypeError(f"{name} must be depth in metres, got a boolean array")
    if arr.dtype == object or not (
        np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)
    ):
        raise TypeError(f"{name} must be a real numeric array of metres, got dtype {arr.dtype}")
    if arr.ndim not in ndim:
        want = " or ".join(f"{d}-D" for d in ndim)
        raise ValueError(f"{name} must be {want} (H, W) / (N, H, W), got shape {arr.shape}")
    if arr.size == 0:
        raise ValueError(f"{name} is empty (shape {arr.shape})")
    arr = arr.astype(np.float32, copy=False)
    nan = np.isnan(arr)
    if np.isinf(arr).any():
        raise ValueError(f"{name} contains infinite values; use 0 for 'no measurement'")
    if not allow_nan and nan.any():
        raise ValueError(
            f"{name} contains NaN; NaN marks pixels to fill and is not allowed here "
            "(use 0 for 'no measurement')"
        )
    # NaN compares False, so this only looks at real values.
    if (arr < 0).any():
        raise ValueError(f"{name} contains negative depth (min {np.nanmin(arr):.3g} m)")
    return arr


def check_mask(mask: object, shape: tuple[int, ...], *, name: str = "hole") -> np.ndarray:
    """Validate a boolean (or 0/1) occlusion mask of the given shape and return it as bool."""
    arr = np.asarray(mask)
    if arr.shape != tuple(shape):
        raise ValueError(f"{name} mask has shape {arr.shape}, expected {tuple(shape)}")
    if arr.dtype != np.bool_:
        if not (np.issubdtype(arr.dtype, np.integer) or np.issubdtype(arr.dtype, np.floating)):
            raise TypeError(f"{name} mask must be boolean or 0/1, got dtype {arr.dtype}")
        if not np.isin(arr, (0, 1)).all():
            raise ValueError(f"{name} mask must contain only 0 and 1")
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
