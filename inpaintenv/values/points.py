"""What a LiDAR scan point may be: finite x, y, z in metres, and, once projected, a depth a map can hold.

Every reader of scan points calls these: :func:`~inpaintenv.data.projection.read_scan` and
:func:`~inpaintenv.data.projection.project_points` (:func:`check_finite`),
:func:`~inpaintenv.data.projection.project_scan` (:func:`check_in_range`, :func:`check_landed`)
and ``fill``'s reader of a scan (:func:`split_far`, :func:`check_landed`).

* A coordinate that is NaN or infinite is not a measurement: the scan is refused, naming how many.
* A point whose depth (its distance along the camera's axis) is beyond
  :data:`~inpaintenv.conventions.DEPTH_LIMIT` (255.996 m, the most a KITTI 16-bit PNG holds)
  cannot be stored: it is left out, as points behind the camera are, and counted
  (:func:`split_far`); :func:`~inpaintenv.data.projection.project_scan` refuses one instead of
  storing it as 255.996 m. When more than :data:`MAX_FAR_SHARE` of the points in front of
  the camera are that far, the scan is not in metres (scaled x10, or another unit) and is refused.
* A scan none of whose points lands in the image does not fit its calibration (all behind
  the camera, another camera or rig): refused (:func:`check_landed`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..conventions import DEPTH_LIMIT
from ..exceptions import CalibrationError, ScanFormatError

__all__ = ["MAX_FAR_SHARE", "PointCounts", "check_finite", "check_in_range", "check_landed", "far_note", "split_far"]

#: The largest share of the points in front of the camera that may lie beyond the PNG limit and
#: be left out. A KITTI HDL-64E scan has none (its returns end near 120 m); the same scan in
#: decimetres (x10) has 6 % (drive 0001 frame 5; see docs/fill.md), so more is a unit mistake.
MAX_FAR_SHARE: float = 0.01


@dataclass(frozen=True)
class PointCounts:
    """Where a scan's points went in a projection: how many in all, behind the camera, beyond the limit, landed."""

    total: int
    behind: int
    far: int
    landed: int

    @property
    def outside(self) -> int:
        """Points in front of the camera, within the limit, that fall beside the image."""
        return self.total - self.behind - self.far - self.landed


def check_finite(xyz: np.ndarray, where: str) -> None:
    """Refuse points with a NaN or infinite coordinate, naming how many (``where``: the file, or "points").

    Raises
    ------
    ScanFormatError
        At least one row of ``xyz`` (``(N, 3)``) is not finite.
    """
    bad = int(np.count_nonzero(~np.isfinite(xyz).all(axis=1)))
    if bad:
        raise ScanFormatError(f"{where}: {bad} of its {len(xyz)} points have a NaN or infinite coordinate; a LiDAR "
                              "scan holds finite x, y, z in metres")


def _far(z: np.ndarray) -> np.ndarray:
    with np.errstate(invalid="ignore"):
        return z > DEPTH_LIMIT


def split_far(points: np.ndarray, z: np.ndarray, min_depth: float, where: str) -> tuple[np.ndarray, int]:
    """``points`` without those whose depth ``z`` is beyond the PNG limit, and how many went.

    Parameters
    ----------
    points : numpy.ndarray
        ``(N, 3)`` or ``(N, 4)``.
    z : numpy.ndarray
        ``(N,)`` their depth along the camera's axis (metres).
    min_depth : float
        Points at this depth or nearer are behind the camera (not counted as in front).
    where : str
        The scan, for the error.

    Raises
    ------
    ScanFormatError
        More than :data:`MAX_FAR_SHARE` of the points in front of the camera are that far.
    """
    far = _far(z)
    n_far = int(np.count_nonzero(far))
    if not n_far:
        return points, 0
    with np.errstate(invalid="ignore"):
        front = int(np.count_nonzero(z > min_depth))
    if n_far > MAX_FAR_SHARE * front:
        raise ScanFormatError(
            f"{where}: {n_far} of its {front} points in front of the camera are farther than {DEPTH_LIMIT:.3f} m "
            f"(up to {float(np.nanmax(z)):.4g} m), the most a KITTI 16-bit PNG holds; a LiDAR scan in metres has "
            f"next to none (over {MAX_FAR_SHARE:.0%} is a unit mistake: scaled x10, or not metres?)")
    return points[~far], n_far


def check_in_range(z: np.ndarray, where: str) -> None:
    """Refuse points whose depth ``z`` is beyond the PNG limit (they would be stored as 255.996 m).

    Raises
    ------
    ScanFormatError
        Naming how many, and how to leave them out.
    """
    n_far = int(np.count_nonzero(_far(z)))
    if n_far:
        raise ScanFormatError(
            f"{where}: {n_far} {'point is' if n_far == 1 else 'points are'} farther than {DEPTH_LIMIT:.3f} m (up to "
            f"{float(np.nanmax(z)):.4g} m), the "
            "most a KITTI 16-bit PNG holds, and would be stored as that; leave them out first "
            "(inpaintenv.data.projection.drop_far_points; fill does, and says how many)")


def far_note(n_far: int) -> str:
    """The line ``fill`` prints for a scan that lost ``n_far`` points (``""`` for none)."""
    if not n_far:
        return ""
    return (f"{n_far} point{'s' * (n_far != 1)} farther than {DEPTH_LIMIT:.3f} m (the most a 16-bit PNG holds) left "
            "out, as points behind the camera are")


def check_landed(counts: PointCounts, where: str, size: tuple[int, int], min_depth: float) -> None:
    """Refuse a projection where no point of the scan lands in the image.

    Parameters
    ----------
    counts : PointCounts
    where : str
        The calibration, for the message.
    size : (int, int)
        The image's width and height.
    min_depth : float
        Points at this depth or nearer counted as behind the camera.

    Raises
    ------
    CalibrationError
        Saying where the points went (behind the camera, beside the image) and what to check.
    """
    if counts.landed:
        return
    w, h = size
    raise CalibrationError(
        f"{where}: no point of the scan lands in the {w}x{h} image ({counts.behind} of its {counts.total} points "
        f"behind the camera or within {min_depth:g} m of it, {counts.outside} beside the image, {counts.far} beyond "
        f"{DEPTH_LIMIT:.3f} m): the "
        "calibration does not fit the scan (another camera, rig or image size?); nothing written")
