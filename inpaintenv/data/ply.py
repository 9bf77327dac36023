"""Reading the point clouds ``fill --points ply`` writes: binary little-endian PLY, float32 x, y, z, intensity.

Only that layout is read (the one :func:`~inpaintenv.data.projection.write_points_ply` writes,
and the usual layout of LiDAR PLYs from Open3D or CloudCompare saved with the same four
properties); any other is one clear error naming what it holds. The vertex count is checked
against the file's size and :data:`~inpaintenv.files.MAX_SCAN_POINTS` before the points are read.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..exceptions import FileTooLargeError, ScanFormatError
from ..files import MAX_SCAN_POINTS, read_bytes, read_head
from ..values.points import check_finite

__all__ = ["read_points_ply"]

_HEADER_MAX = 4096
_LAYOUT = ["property float x", "property float y", "property float z", "property float intensity"]


def read_points_ply(path: str | os.PathLike) -> np.ndarray:
    """The ``(N, 4)`` float32 points (x, y, z, intensity) of a binary little-endian PLY.

    Raises
    ------
    ScanFormatError
        Not a PLY of that layout, a size that does not match its vertex count, or a
        coordinate that is NaN or infinite.
    FileTooLargeError
        More than :data:`~inpaintenv.files.MAX_SCAN_POINTS` points.
    UnsafeFileError, OSError
        A FIFO or device (refused at once), a missing or unreadable file.
    """
    path = Path(path)
    head, size = read_head(path, _HEADER_MAX, "point cloud")
    end = head.find(b"end_header\n")
    if not head.startswith(b"ply\n") or end < 0:
        raise ScanFormatError(f"{path} is not a PLY point cloud (no 'ply' ... 'end_header' header in its first "
                              f"{_HEADER_MAX} bytes)")
    lines = [ln.strip() for ln in head[:end].decode("ascii", "replace").splitlines()]
    count = next((ln.split()[2] for ln in lines if ln.startswith("element vertex ")), None)
    props = [ln for ln in lines if ln.startswith("property ")]
    if "format binary_little_endian 1.0" not in lines or props != _LAYOUT or count is None or not count.isdigit():
        raise ScanFormatError(f"{path}: a PLY of binary little-endian float x, y, z, intensity vertices is read "
                              f"(what fill --points ply writes); this one has {', '.join(props) or 'no properties'}")
    n, start = int(count), end + len(b"end_header\n")
    if n > MAX_SCAN_POINTS:
        raise FileTooLargeError(f"{path} declares {n:,} points, more than the {MAX_SCAN_POINTS:,} a scan may have; "
                                "not read")
    if size != start + 16 * n:
        raise ScanFormatError(f"{path} declares {n:,} points ({16 * n:,} bytes) but holds {size - start:,} bytes "
                              "after its header")
    data = read_bytes(path, "point cloud", limit=start + 16 * n)
    points = np.frombuffer(data, dtype="<f4", offset=start).reshape(n, 4).astype(np.float32)
    check_finite(points[:, :3], str(path))
    return points
