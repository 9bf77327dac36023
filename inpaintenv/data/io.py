"""Reading and writing KITTI depth PNGs (uint16, metres = value / 256, 0 = no data)."""

from __future__ import annotations

import os
from pathlib import Path

import cv2
import numpy as np

from ..conventions import check_depth

__all__ = [
    "KITTI_DEPTH_SCALE",
    "DepthFormatError",
    "depth_from_uint16",
    "read_depth_png",
    "read_depth_png_raw",
    "write_depth_png",
]

#: KITTI stores depth as uint16 PNG with metres = value / 256.
KITTI_DEPTH_SCALE: float = 256.0


class DepthFormatError(ValueError):
    """A file exists but is not a KITTI 16-bit single-channel depth PNG."""


def read_depth_png(path: str | os.PathLike) -> np.ndarray:
    """Read a KITTI depth PNG as float32 metres.

    Parameters
    ----------
    path : path-like
        A 16-bit single-channel PNG.

    Returns
    -------
    numpy.ndarray
        ``(H, W)`` float32 depth in metres, 0 where there is no measurement.

    Raises
    ------
    FileNotFoundError
        If the file does not exist.
    DepthFormatError
        If the file is unreadable, truncated, 8-bit, or has more than one channel.
    """
    return depth_from_uint16(read_depth_png_raw(path))


def read_depth_png_raw(path: str | os.PathLike) -> np.ndarray:
    """Read a KITTI depth PNG as its stored uint16 values (metres * 256), validated.

    Cropping these before :func:`depth_from_uint16` converts only the kept pixels.
    Raises as :func:`read_depth_png`.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"depth PNG not found: {path}")
    # IMREAD_UNCHANGED keeps 16 bits and the channel count, so we can reject bad files.
    raw = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if raw is None:
        raise DepthFormatError(f"cannot decode {path}: not an image, or truncated/corrupt")
    if raw.ndim != 2:
        raise DepthFormatError(
            f"{path} has {raw.shape[2]} channels; a KITTI depth map is single-channel 16-bit"
        )
    if raw.dtype != np.uint16:
        raise DepthFormatError(
            f"{path} is {raw.dtype} ({8 * raw.dtype.itemsize}-bit); KITTI depth must be a "
            "16-bit PNG (metres = value / 256)"
        )
    return raw


def depth_from_uint16(raw: np.ndarray) -> np.ndarray:
    """KITTI uint16 values to contiguous float32 metres in one pass (exact: /256 is a power of 2)."""
    return np.multiply(raw, np.float32(1.0 / KITTI_DEPTH_SCALE), dtype=np.float32)


def write_depth_png(path: str | os.PathLike, depth: np.ndarray) -> None:
    """Write float metres as a KITTI 16-bit depth PNG (values rounded to 1/256 m).

    Parameters
    ----------
    path : path-like
        Target file; must end in ``.png`` (any other suffix would make OpenCV pick
        another, possibly 8-bit, format).
    depth : array-like
        ``(H, W)`` real-valued metres, 0 = no measurement, finite, non-negative, at
        most :data:`~inpaintenv.conventions.DEPTH_LIMIT` (65535 / 256 m).

    Raises
    ------
    ValueError
        On a suffix other than ``.png``; depth that is not 2-D, is empty, negative,
        NaN/inf or above the 16-bit range; or a 3-D ``(H, W, 1)`` array.
    TypeError
        If depth is boolean, complex or not numeric.
    OSError
        If OpenCV cannot write the file.
    """
    path = Path(path)
    if path.suffix.lower() != ".png":
        raise ValueError(f"depth PNG path must end in .png, got {str(path)!r}")
    # The shared check refuses bool/complex/object, empty, NaN/inf, negative and
    # > 65535/256 m arrays with messages that name the problem.
    check_depth(depth, name="depth to write", ndim=(2,))
    # Scale in float64 so rounding to 1/256 m does not depend on float32 precision. No
    # overflow check needed: check_depth refused anything whose float32 value exceeds
    # 65535/256 m, so what passes is at most half a float32 step (8e-6 m) above it and
    # rounds to at most 65535.
    scaled = np.rint(np.asarray(depth, dtype=np.float64) * KITTI_DEPTH_SCALE)
    path.parent.mkdir(parents=True, exist_ok=True)
    if not cv2.imwrite(str(path), scaled.astype(np.uint16)):
        raise OSError(f"could not write {path}")
