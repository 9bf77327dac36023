"""Reading and writing KITTI depth PNGs (uint16, metres = value / 256, 0 = no data)."""

from __future__ import annotations

import os
from pathlib import Path

import cv2
import numpy as np

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

    Raises
    ------
    ValueError
        If depth is not 2-D, is negative/NaN/inf, or exceeds the uint16 range (256 m).
    """
    depth = np.asarray(depth, dtype=np.float64)
    if depth.ndim != 2:
        raise ValueError(f"depth must be 2-D, got shape {depth.shape}")
    if not np.isfinite(depth).all() or (depth < 0).any():
        raise ValueError("depth to write must be finite and non-negative")
    scaled = np.rint(depth * KITTI_DEPTH_SCALE)
    if scaled.max(initial=0) > np.iinfo(np.uint16).max:
        raise ValueError("depth exceeds 255.99 m, the range of KITTI's uint16 encoding")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if not cv2.imwrite(str(path), scaled.astype(np.uint16)):
        raise OSError(f"could not write {path}")
