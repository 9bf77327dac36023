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

import io
import os
from pathlib import Path

import numpy as np

from ..conventions import as_depth_array, check_depth
from ..exceptions import InvalidInputError
from ..files import write_bytes_atomic
from ..values.depth import check_metres_scale
from .io import DepthFormatError, load_array, read_depth_png, read_png, write_depth_png

__all__ = ["DEPTH_SUFFIXES", "MASK_SUFFIXES", "read_depth_file", "read_mask_file", "write_depth_file"]

#: Suffixes :func:`read_depth_file` reads (lower case).
DEPTH_SUFFIXES = (".png", ".npy", ".npz")
#: Suffixes :func:`read_mask_file` reads (lower case).
MASK_SUFFIXES = (".png", ".npy", ".npz")
#: The key of the depth array in an ``.npz`` holding several.
NPZ_KEY = "depth"
#: The key of the mask array in an ``.npz`` holding several.
MASK_KEY = "mask"


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
    UnsafeFileError
        A FIFO, device or socket (refused at once, never waited on).
    FileTooLargeError
        A PNG or array declaring more than ``inpaintenv.files.MAX_FRAME_PIXELS`` values
        (checked from its header, before anything is decoded or allocated).
    DepthFormatError
        If the file cannot be decoded or is not one 2-D map of metres (the message names
        the file and the problem: an integer array, negative or infinite depth, ...), or every
        measurement is under a metre (a PNG of plain metres, a normalised array:
        :func:`inpaintenv.values.depth.check_metres_scale`).
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".png":
        depth = read_depth_png(path)
        check_metres_scale(depth, str(path), png=True)
        return depth
    if suffix not in DEPTH_SUFFIXES:
        raise DepthFormatError(f"{path}: not a depth file (expected {', '.join(DEPTH_SUFFIXES)})")
    arr = load_array(path, "depth file", key=(NPZ_KEY,))
    try:
        as_depth_array(arr, "the array")
        check_depth(arr, name="the array", allow_nan=True, ndim=(2,))
    except (TypeError, ValueError) as exc:
        raise DepthFormatError(f"{path}: {exc}") from None
    check_metres_scale(arr, str(path), png=False)
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
    UnsafeFileError, FileTooLargeError
        As :func:`read_depth_file`.
    DepthFormatError
        If it cannot be decoded (a PNG by its signature, whatever its name) or is not one
        2-D mask (e.g. holds NaN).
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in MASK_SUFFIXES:
        raise DepthFormatError(f"{path}: not a mask file (expected {', '.join(MASK_SUFFIXES)})")
    if suffix == ".png":
        # Bytes read by Python and decoded in memory, the declared size checked first.
        img = read_png(path, "mask")
        if img.ndim == 3:
            img = img[..., :3]  # colour channels; alpha says nothing about holes
        return (img != 0).any(axis=-1) if img.ndim == 3 else img != 0
    arr = load_array(path, "mask", key=(MASK_KEY,))
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
        The suffix chooses the format; parent folders are created. Written whole or not at
        all, never through a link (:func:`inpaintenv.files.write_atomic`).
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
    buf = io.BytesIO()  # a file object: np.save would otherwise append .npy to any other name
    if suffix == ".npy":
        np.save(buf, arr, allow_pickle=False)
    else:
        np.savez_compressed(buf, **{NPZ_KEY: arr})
    write_bytes_atomic(path, buf.getvalue(), "depth file")
