"""LiDAR scans as files, projected into a depth map as KITTI's ``velodyne_raw`` maps are, and back.

A scan is an ``(N, 4)`` float32 array (x, y, z in metres in the LiDAR frame, reflectance),
stored by KITTI as a flat ``.bin`` of float32. :func:`project_scan` is the plain projection
KITTI's single-scan input maps are made by: each point goes through
:attr:`Calibration.matrix <inpaintenv.data.calibration.Calibration.matrix>`, depth is the
third coordinate, points at 0.1 m or nearer are dropped, ``(u, v)`` are rounded to the
nearest pixel, the nearest point wins a pixel, and depth is rounded to 1/256 m (the 16-bit
PNG step), so that ``write_depth_png`` of the result is the map KITTI would store.
:func:`depth_to_points` is its inverse: each chosen pixel's centre at its depth, back in the
LiDAR frame.

>>> points = read_scan("velodyne_points/data/0000000005.bin")      # doctest: +SKIP
>>> depth = project_scan(points, read_calibration("2011_09_26"))    # doctest: +SKIP
>>> xyz = depth_to_points(depth, calibration)                       # doctest: +SKIP
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .calibration import Calibration
from .io import KITTI_DEPTH_SCALE
from ..exceptions import CalibrationError, FileTooLargeError, InvalidInputError, ScanFormatError
from ..files import MAX_SCAN_POINTS, open_regular, write_bytes_atomic
from ..values.points import PointCounts, check_finite, check_in_range, check_landed, split_far

__all__ = [
    "MIN_SCAN_DEPTH", "ScanFormatError", "depth_to_points", "drop_far_points", "project_points", "project_scan",
    "read_scan",
    "write_points_bin", "write_points_ply",
]

#: Points at this depth or nearer (metres) are dropped by the projection, as KITTI's tool drops them.
MIN_SCAN_DEPTH: float = 0.1
_POINT_BYTES = 16  # x, y, z, reflectance as float32
_CHUNK_POINTS = 1 << 20  # points projected at a time (about 100 MB of float64 work arrays)


def read_scan(path: str | os.PathLike) -> np.ndarray:
    """Read a KITTI ``.bin`` LiDAR scan.

    Parameters
    ----------
    path : path-like
        A flat file of float32 x, y, z, reflectance, 16 bytes a point, at most
        :data:`~inpaintenv.files.MAX_SCAN_POINTS` points (checked from its size before reading).

    Returns
    -------
    numpy.ndarray
        ``(N, 4)`` float32.

    Raises
    ------
    FileNotFoundError
        If there is no file.
    UnsafeFileError
        A FIFO, device or socket (refused at once, never waited on).
    FileTooLargeError
        More than :data:`~inpaintenv.files.MAX_SCAN_POINTS` points.
    ScanFormatError
        If the file is empty, its size is not a whole number of points, or a coordinate is
        NaN or infinite.
    """
    path = Path(path)
    points = _read_points(path)
    check_finite(points[:, :3], str(path))
    return points


def _read_points(path: Path) -> np.ndarray:
    """The float32 points of the ``.bin`` file ``path``, its size checked first and read in place (no second copy)."""
    with os.fdopen(open_regular(path, "scan"), "rb") as f:  # a FIFO or device is refused here, never waited on
        size = os.fstat(f.fileno()).st_size
        if size > MAX_SCAN_POINTS * _POINT_BYTES:
            raise FileTooLargeError(
                f"scan {path} is {size:,} bytes ({size // _POINT_BYTES:,} points), more than the {MAX_SCAN_POINTS:,} "
                "points a scan may have (inpaintenv.files.MAX_SCAN_POINTS); not read")
        if size == 0 or size % _POINT_BYTES:
            raise ScanFormatError(
                f"{path} is not a KITTI LiDAR scan: {size} bytes is not a whole, non-zero number of points "
                "(N x 4 float32: x, y, z, reflectance)"
            )
        points = np.empty((size // _POINT_BYTES, 4), dtype="<f4")
        view, got = memoryview(points).cast("B"), 0
        try:
            while got < size and (n := f.readinto(view[got:])):
                got += n
        except OSError as exc:
            raise OSError(f"cannot read scan {path}: {exc.strerror or exc}") from None
    if got != size:
        raise ScanFormatError(f"{path} changed while it was read ({got} of {size} bytes); not read")
    return points


def _as_points(points: np.ndarray) -> np.ndarray:
    pts = np.asarray(points)
    if pts.ndim != 2 or pts.shape[1] not in (3, 4) or not np.issubdtype(pts.dtype, np.floating):
        raise InvalidInputError(f"points must be a float (N, 3) or (N, 4) array, got {pts.dtype} of shape {pts.shape}")
    return pts


def project_points(points: np.ndarray, calibration: Calibration) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Continuous image coordinates and depth of every point (no rounding, nothing dropped).

    Parameters
    ----------
    points : numpy.ndarray
        ``(N, 3)`` or ``(N, 4)`` float, metres in the LiDAR frame.
    calibration : Calibration

    Returns
    -------
    u, v, z : numpy.ndarray
        ``(N,)`` float64 column, row and depth (metres); ``u, v`` are meaningless where
        ``z <= 0`` (behind the camera).
    """
    xyz = _as_points(points)[:, :3].astype(np.float64)
    check_finite(xyz, "points")
    m = calibration.matrix
    with np.errstate(all="ignore"):  # overflow: refused below, by whoever uses the values
        uvw = xyz @ m[:, :3].T
        del xyz  # a 16 M-point scan: each float64 copy is 384 MB
        uvw += m[:, 3]
        z = uvw[:, 2]
        return uvw[:, 0] / z, uvw[:, 1] / z, z


def project_scan(
    points: np.ndarray, calibration: Calibration, *, quantize: bool = True, return_index: bool = False,
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Project a scan into a depth map as KITTI's ``velodyne_raw`` maps are made.

    Parameters
    ----------
    points : numpy.ndarray
        ``(N, 3)`` or ``(N, 4)`` float, metres in the LiDAR frame.
    calibration : Calibration
        With an image size (see :meth:`Calibration.image_size`).
    quantize : bool
        Round depth to 1/256 m, the step of KITTI's 16-bit PNG (the default: the map equals
        what ``read_depth_png`` gives of the PNG KITTI would store). False keeps float32 depth.
    return_index : bool
        Also return, per pixel, the index of the point that won it (-1 where none).

    Returns
    -------
    depth : numpy.ndarray
        ``(height, width)`` float32 metres, 0 where no point lands.
    index : numpy.ndarray
        ``(height, width)`` int64, only with ``return_index``.

    Raises
    ------
    ScanFormatError
        A point with a NaN or infinite coordinate, or one farther than the PNG limit
        (255.996 m; it would be stored as that: leave such points out with :func:`drop_far_points`).
    CalibrationError
        A point in front of the camera projects to an infinite or NaN pixel or depth, or no
        point lands in the image (the calibration does not fit the scan).
    """
    width, height = calibration.image_size()
    pts = _as_points(points)
    behind = landed = 0
    # In chunks, keeping the nearest point of each pixel so far: a 16 M-point scan's float64
    # coordinates and sort keys would otherwise take gigabytes at once.
    nearest = np.full(height * width, np.inf)
    index = np.full(height * width, -1, dtype=np.int64)
    for start in range(0, len(pts), _CHUNK_POINTS):
        pixel, z, idx, n_behind = _kept_in_image(pts[start:start + _CHUNK_POINTS], start, calibration, width, height)
        behind, landed = behind + n_behind, landed + len(idx)
        # Sort by pixel, then depth: the first point of each pixel is the nearest (ties: the earlier point).
        order = np.lexsort((z, pixel))
        pixel, z, idx = pixel[order], z[order], idx[order]
        first = np.ones(len(pixel), dtype=bool)
        first[1:] = pixel[1:] != pixel[:-1]
        pixel, z, idx = pixel[first], z[first], idx[first]
        closer = z < nearest[pixel]  # strictly: on a tie the earlier chunk's point stays
        nearest[pixel[closer]], index[pixel[closer]] = z[closer], idx[closer]
    check_landed(PointCounts(len(pts), behind, 0, landed), _name(calibration), (width, height), MIN_SCAN_DEPTH)
    depth = np.where(index >= 0, nearest, 0.0)
    if quantize:  # every depth is within the PNG limit (checked): rounding never passes 65535
        depth = np.rint(depth * KITTI_DEPTH_SCALE) / KITTI_DEPTH_SCALE
    depth = depth.astype(np.float32).reshape(height, width)
    return (depth, index.reshape(height, width)) if return_index else depth


def _kept_in_image(
    points: np.ndarray, start: int, calibration: Calibration, width: int, height: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Pixel (flat), depth and index (from ``start``) of the points that land in the image, in their order;
    how many points are behind the camera."""
    u, v, z = project_points(points, calibration)
    with np.errstate(invalid="ignore"):
        behind = ~(z > MIN_SCAN_DEPTH)
    for values in (z, u, v):  # u, v only count in front of the camera
        _check_finite(np.isfinite(values) | (behind if values is not z else False), calibration,
                      "projects finite points")
    check_in_range(z, "points")
    with np.errstate(invalid="ignore"):
        ur, vr = np.rint(u), np.rint(v)  # the nearest pixel
        keep = ~behind & (ur >= 0) & (ur < width) & (vr >= 0) & (vr < height)
    idx = np.flatnonzero(keep)
    return vr[idx].astype(np.int64) * width + ur[idx].astype(np.int64), z[idx], idx + start, int(behind.sum())


def drop_far_points(points: np.ndarray, calibration: Calibration, where: str = "points") -> tuple[np.ndarray, int]:
    """``points`` without those farther (in depth) than a KITTI 16-bit PNG can hold, and how many went.

    Such a point cannot be stored in a map: :func:`project_scan` refuses it rather than store
    it as 255.996 m. ``fill`` leaves them out (as points behind the camera) and says how many.

    Parameters
    ----------
    points : numpy.ndarray
        ``(N, 3)`` or ``(N, 4)`` float, metres in the LiDAR frame.
    calibration : Calibration
    where : str
        The scan, for the error.

    Returns
    -------
    kept : numpy.ndarray
        The rows of ``points`` within the limit (``points`` itself when none went).
    n_far : int

    Raises
    ------
    ScanFormatError
        A NaN or infinite coordinate; more than :data:`~inpaintenv.values.points.MAX_FAR_SHARE`
        of the points in front of the camera beyond the limit (a scan not in metres).
    """
    pts = _as_points(points)
    z = np.empty(len(pts))
    for start in range(0, len(pts), _CHUNK_POINTS):  # a large scan's work arrays stay small
        z[start:start + _CHUNK_POINTS] = project_points(pts[start:start + _CHUNK_POINTS], calibration)[2]
    return split_far(pts, z, MIN_SCAN_DEPTH, where)


def _name(calibration: Calibration) -> str:
    return f"calibration {calibration.source or '(given as a matrix)'}"


def depth_to_points(depth: np.ndarray, calibration: Calibration, mask: np.ndarray | None = None) -> np.ndarray:
    """Back-project pixels of a depth map into the LiDAR frame (the inverse of :func:`project_scan`).

    Parameters
    ----------
    depth : numpy.ndarray
        ``(H, W)`` metres, 0 = no measurement.
    calibration : Calibration
        The one the map was projected with.
    mask : numpy.ndarray of bool, optional
        ``(H, W)``: only these pixels (default: every pixel with positive, finite depth);
        pixels without positive depth are skipped either way.

    Returns
    -------
    numpy.ndarray
        ``(M, 3)`` float64 x, y, z in metres, one row per pixel in row-major order: the
        pixel's centre ``(column, row)`` at its depth, which projects back onto that pixel.

    Raises
    ------
    CalibrationError
        A point would be infinite or NaN (a calibration out of range), naming the calibration.
    """
    d = np.asarray(depth)
    if d.ndim != 2:
        raise InvalidInputError(f"depth must be (H, W), got shape {d.shape}")
    with np.errstate(invalid="ignore"):
        chosen = np.isfinite(d) & (d > 0)
    if mask is not None:
        m = np.asarray(mask, dtype=bool)
        if m.shape != d.shape:
            raise InvalidInputError(f"mask has shape {m.shape}, depth {d.shape}")
        chosen &= m
    rows, cols = np.nonzero(chosen)
    a, b = calibration.matrix[:, :3], calibration.matrix[:, 3]
    xyz = np.empty((len(rows), 3))
    for s in range(0, len(rows), _CHUNK_POINTS):  # in chunks: a large frame's work arrays stay small
        r, c = rows[s:s + _CHUNK_POINTS], cols[s:s + _CHUNK_POINTS]
        z = d[r, c].astype(np.float64)
        with np.errstate(all="ignore"):
            xyz[s:s + len(r)] = np.linalg.solve(a, np.stack([c * z, r * z, z]) - b[:, None]).T
    _check_finite(np.isfinite(xyz), calibration, "back-projects depth")
    return xyz


def _check_finite(finite: np.ndarray, calibration: Calibration, action: str) -> None:
    """Refuse non-finite results of a calibration (``finite`` False anywhere): they would be written as points or depth."""
    if not finite.all():
        raise CalibrationError(
            f"{_name(calibration)} {action} to infinite or NaN values (a "
            "matrix out of range, or values beyond any sensor's); nothing written"
        )


def _with_reflectance(points: np.ndarray) -> np.ndarray:
    pts = _as_points(points)
    if pts.shape[1] == 3:
        pts = np.hstack([pts, np.zeros((len(pts), 1), dtype=pts.dtype)])
    return np.ascontiguousarray(pts, dtype="<f4")


def write_points_bin(path: str | os.PathLike, points: np.ndarray) -> None:
    """Write points as a KITTI ``.bin`` scan (float32 x, y, z, reflectance; reflectance 0 for ``(N, 3)``).

    Written whole or not at all, never through a link (:func:`inpaintenv.files.write_atomic`).
    """
    write_bytes_atomic(path, _with_reflectance(points).tobytes(), "scan")


def write_points_ply(path: str | os.PathLike, points: np.ndarray) -> None:
    """Write points as a binary PLY (float32 x, y, z, intensity), readable by Open3D, CloudCompare, MeshLab.

    Written whole or not at all, never through a link (:func:`inpaintenv.files.write_atomic`).
    """
    pts = _with_reflectance(points)
    header = (
        "ply\nformat binary_little_endian 1.0\ncomment written by inpaintenv\n"
        f"element vertex {len(pts)}\nproperty float x\nproperty float y\nproperty float z\n"
        "property float intensity\nend_header\n"
    )
    write_bytes_atomic(path, header.encode("ascii") + pts.tobytes(), "point cloud")
