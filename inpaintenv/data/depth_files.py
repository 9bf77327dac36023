"""Depth maps and hole masks as files: KITTI 16-bit PNG, ``.npy`` and ``.npz``.

Depth files:

* ``.png``: KITTI's 16-bit single-channel PNG, metres x 256, 0 = no measurement (read and
  written by :func:`~inpaintenv.data.io.read_depth_png` / :func:`~inpaintenv.data.io.write_depth_png`);
* ``.npy``: one 2-D floating-point array of metres, NaN = pixel to fill, 0 = no measurement;
* ``.npz``: the same array, as its only member or under the key ``depth``.

Mask files (``nonzero = fill``): a PNG of any bit depth (grey, or colour where any colour
channel is nonzero; an alpha channel is ignored), or an ``.npy`` / ``.npz`` 2-D array of
booleans or numbers.

>>> depth = read_depth_file("frame.npy")                  # doctest: +SKIP
>>> write_depth_file("filled/frame.png", filled)          # doctest: +SKIP
"""

from __future__ import annotations

import os
import zipfile
from pathlib import Path

import cv2
import numpy as np

from ..conventions import as_depth_array, check_depth
from ..exceptions import InvalidInputError
from .io import DepthFormatError, read_depth_png, write_depth_png

__all__ = ["DEPTH_SUFFIXES", "MASK_SUFFIXES", "read_depth_file", "read_mask_file", "write_depth_file"]

#: Suffixes :func:`read_depth_file` reads (lower case).
DEPTH_SUFFIXES = (".png", ".npy", ".npz")
#: Suffixes :func:`read_mask_file` reads (lower case).
MASK_SUFFIXES = (".png", ".npy", ".npz")
#: The key of the depth array in an ``.npz`` holding several.
NPZ_KEY = "depth"


def _load_array(path: Path, what: str) -> np.ndarray:
    """The one array of an ``.npy``, or of an ``.npz`` (its only member, else ``depth``/``mask``)."""
    if not path.is_file():
        raise FileNotFoundError(f"{what} not found: {path}")
    try:
        loaded = np.load(path, allow_pickle=False)
    except (ValueError, OSError, EOFError, zipfile.BadZipFile) as exc:
        raise DepthFormatError(f"cannot read {path}: not a NumPy {path.suffix} file, or truncated ({exc})") from None
    if isinstance(loaded, np.ndarray):
        return loaded
    with loaded:
        keys = list(loaded.files)
        key = keys[0] if len(keys) == 1 else next((k for k in (NPZ_KEY, "mask") if k in keys), None)
        if key is None:
            raise DepthFormatError(f"{path} holds the arrays {keys}; name the {what} array {NPZ_KEY!r} or store one")
        try:
            return loaded[key]
        except (ValueError, OSError, zipfile.BadZipFile) as exc:
            raise DepthFormatError(f"cannot read array {key!r} of {path}: {exc}") from None


def read_depth_file(path: str | os.PathLike) -> np.ndarray:
    """Read a depth map from a KITTI PNG, ``.npy`` or ``.npz`` (see the module docstring).

    Parameters
    ----------
    path : path-like

    Returns
    -------
    numpy.ndarray
        ``(H, W)`` floating-point metres, 0 = no measurement, NaN = fill (arrays only).
        float32 for a PNG; an array keeps its floating dtype, so what is written back is
        bit-identical where it was measured.

    Raises
    ------
    FileNotFoundError
        If there is no file.
    DepthFormatError
        If the file cannot be decoded or is not one 2-D map of metres (the message names
        the file and the problem: an integer array, negative or infinite depth, ...).
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".png":
        return read_depth_png(path)
    if suffix not in DEPTH_SUFFIXES:
        raise DepthFormatError(f"{path}: not a depth file (expected {', '.join(DEPTH_SUFFIXES)})")
    arr = _load_array(path, "depth file")
    try:
        as_depth_array(arr, "the array")
        check_depth(arr, name="the array", allow_nan=True, ndim=(2,))
    except (TypeError, ValueError) as exc:
        raise DepthFormatError(f"{path}: {exc}") from None
    return np.ascontiguousarray(arr)


def read_mask_file(path: str | os.PathLike) -> np.ndarray:
    """Read a hole mask (nonzero = fill) from a PNG, ``.npy`` or ``.npz``.

    Returns
    -------
    numpy.ndarray
        ``(H, W)`` bool, True = fill.

    Raises
    ------
    FileNotFoundError
        If there is no file.
    DepthFormatError
        If it cannot be decoded or is not one 2-D mask (e.g. holds NaN).
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in MASK_SUFFIXES:
        raise DepthFormatError(f"{path}: not a mask file (expected {', '.join(MASK_SUFFIXES)})")
    if suffix == ".png":
        if not path.is_file():
            raise FileNotFoundError(f"mask not found: {path}")
        img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        if img is None:
            raise DepthFormatError(f"cannot decode {path}: not an image, or truncated/corrupt")
        if img.ndim == 3:
            img = img[..., :3]  # colour channels; alpha says nothing about holes
        return (img != 0).any(axis=-1) if img.ndim == 3 else img != 0
    arr = _load_array(path, "mask")
    if arr.ndim != 2 or not (arr.dtype == np.bool_ or np.issubdtype(arr.dtype, np.number)):
        raise DepthFormatError(f"{path}: a mask is one 2-D array of booleans or numbers, got {arr.dtype} "
                               f"of shape {arr.shape}")
    if np.issubdtype(arr.dtype, np.inexact) and not np.isfinite(arr).all():
        raise DepthFormatError(f"{path}: the mask holds NaN or inf; use nonzero = fill, 0 = keep")
    return arr != 0


def write_depth_file(path: str | os.PathLike, depth: np.ndarray) -> None:
    """Write a depth map as a KITTI PNG (``.png``, rounded to 1/256 m), ``.npy`` or ``.npz`` (as given).

    Parameters
    ----------
    path : path-like
        The suffix chooses the format; parent folders are created.
    depth : numpy.ndarray
        ``(H, W)`` floating-point metres, 0 = no measurement (NaN only in an array file).

    Raises
    ------
    ValueError
        On another suffix, or depth a PNG cannot hold (see :func:`~inpaintenv.data.io.write_depth_png`).
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".png":
        write_depth_png(path, depth)
        return
    if suffix not in (".npy", ".npz"):
        raise InvalidInputError(f"a depth file ends in {', '.join(DEPTH_SUFFIXES)}, got {str(path)!r}")
    arr = as_depth_array(depth, "depth to write")
    if arr.ndim != 2:
        raise InvalidInputError(f"depth to write must be (H, W), got shape {arr.shape}")
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("wb") as f:  # a file object: np.save would otherwise append .npy to any other name
        if suffix == ".npy":
            np.save(f, arr, allow_pickle=False)
        else:
            np.savez_compressed(f, **{NPZ_KEY: arr})
