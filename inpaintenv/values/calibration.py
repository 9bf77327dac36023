"""What a projection (calibration) may be: finite, invertible, right-handed, of the scan's rig.

Called by :class:`~inpaintenv.data.calibration.Calibration` (every projection, however made or
read: :func:`check_projection`), by :func:`~inpaintenv.data.calibration.read_calibration` (a
file's rotations: :func:`check_rotation`) and by ``fill``'s reader of a scan (the scan's file
layout names the rig and day its calibration must be of: :func:`check_scan_fits`).

A projection ``M = K R [I | t]`` takes a LiDAR point to ``z (u, v, 1)``. With the image's
``u`` to the right and ``v`` down, ``det M[:, :3] = fx fy det R`` is positive for every real
camera; a negated depth row (or one mirrored image axis) makes it negative and lets points
behind the camera land in the image, so it is refused. Which way the camera looks in the
LiDAR's frame is not checked: a camera turned backwards (its depth row and one image row
negated) is a real rear camera, and points already in the camera's frame (``Tr`` the identity)
are a real use.
"""

from __future__ import annotations

import re
from pathlib import PurePath

import numpy as np

from ..exceptions import CalibrationError

__all__ = ["KITTI360_DATE", "MAX_CONDITION", "ODOMETRY_DAYS", "ROTATION_TOLERANCE", "check_projection",
           "check_rotation", "check_scan_fits", "recording_day", "rig_of_scan"]

#: The largest condition number of a projection's 3 x 3 part accepted (a camera's is of the order of its focal length).
MAX_CONDITION: float = 1e8
#: The recording date of every KITTI-360 drive folder (``2013_05_28_drive_0000_sync``); KITTI raw days are in 2011.
KITTI360_DATE = "2013_05_28"
#: How far a calibration file's rotation may be from orthonormal (largest entry of ``R Rᵀ - I``): KITTI's are within
#: 1e-6 (raw ``R`` 9e-8, ``R_rect_00`` 8e-8, odometry ``Tr`` 8e-8, KITTI-360 ``T_cam0_to_velo`` 6e-11 and
#: ``R_rect_00`` 1e-6 on kitti-raw), as printed to 7 to 9 digits.
ROTATION_TOLERANCE: float = 1e-3
_DRIVE = re.compile(r"(\d{4}_\d{2}_\d{2})_drive_\d{4}_sync")
_DAY = re.compile(r"2011_\d{2}_\d{2}")
#: The KITTI raw day each odometry sequence with ground truth was recorded on (the odometry devkit's table).
ODOMETRY_DAYS = {"00": "2011_10_03", "01": "2011_10_03", "02": "2011_10_03", "03": "2011_09_26",
                 **{f"{n:02d}": "2011_09_30" for n in range(4, 11)}}


def check_projection(matrix: object, where: str) -> np.ndarray:
    """``matrix`` as a ``(3, 4)`` float64 projection, or one CalibrationError (``where``: ``"path: "`` or ``""``).

    Raises
    ------
    CalibrationError
        Not 3 x 4 and finite; singular; badly conditioned (:data:`MAX_CONDITION`); or not
        right-handed (``det M[:, :3] < 0``: a negated depth row, points behind the camera would land in the image).
    """
    given = np.asarray(matrix)
    if not (np.issubdtype(given.dtype, np.floating) or np.issubdtype(given.dtype, np.integer)):
        raise CalibrationError(f"{where}a projection matrix is 3 x 4 real numbers, got {given.dtype}")
    m = given.astype(np.float64)
    if m.shape != (3, 4):
        raise CalibrationError(f"{where}a projection matrix is 3 x 4 and finite, got shape {m.shape}")
    if not np.isfinite(m).all():
        raise CalibrationError(f"{where}the projection matrix holds NaN or infinite values")
    with np.errstate(all="ignore"):
        det, cond = np.linalg.det(m[:, :3]), np.linalg.cond(m[:, :3])
    if abs(det) < 1e-12:
        raise CalibrationError(f"{where}the projection matrix is singular (cannot back-project)")
    if not cond <= MAX_CONDITION:
        raise CalibrationError(
            f"{where}the projection matrix is badly conditioned (condition number {cond:.3g}, more than "
            f"{MAX_CONDITION:.0e}; a camera's is of the order of its focal length in pixels): back-projected "
            "points would be meaningless"
        )
    if det < 0:
        raise CalibrationError(
            f"{where}the projection matrix is not right-handed (the determinant of its 3 x 3 part is {det:.3g} < 0): "
            "its depth row, or one image axis, is negated, so points behind the camera would land in the image; a "
            "camera's depth increases forward, u to the right and v down"
        )
    return m


def check_rotation(r: np.ndarray, what: str) -> None:
    """Refuse a calibration file's rotation (``R``, ``R_rect_00``, the 3 x 3 of ``Tr`` or ``T_cam0_to_velo``)
    that is not one: not orthonormal within :data:`ROTATION_TOLERANCE`, or a reflection.

    Raises
    ------
    CalibrationError
        Naming ``what`` (its file and key) and how far it is from a rotation.
    """
    off = float(np.abs(r @ r.T - np.eye(3)).max())
    if not off <= ROTATION_TOLERANCE:
        raise CalibrationError(f"{what} is not a rotation (R Rᵀ differs from the identity by {off:.3g}; a "
                               "calibration's rotations are orthonormal): a scaled, sheared or mistyped matrix")
    if np.linalg.det(r) < 0:
        raise CalibrationError(f"{what} is a reflection (determinant -1), not a rotation: a negated row or axis")


def rig_of_scan(path: PurePath) -> str | None:
    """The rig a scan's file layout names: ``"kitti360"``, ``"kitti"`` (raw and odometry), or None when unknown.

    A ``<date>_drive_<nnnn>_sync`` folder on the path is KITTI-360's when dated
    :data:`KITTI360_DATE`, KITTI raw's when dated 2011; ``sequences/<nn>/velodyne`` is odometry's.
    """
    parts = path.parts
    for part in reversed(parts):
        match = _DRIVE.fullmatch(part)
        if match:
            date = match.group(1)
            return "kitti360" if date == KITTI360_DATE else "kitti" if date.startswith("2011_") else None
    for i in range(len(parts) - 2):
        if parts[i] == "sequences" and parts[i + 1].isascii() and parts[i + 1].isdigit() and parts[i + 2] == "velodyne":
            return "kitti"
    return None


def recording_day(path: PurePath) -> str | None:
    """The KITTI raw day a scan or calibration path names, or None: a ``2011_MM_DD_drive_NNNN_sync`` or
    ``2011_MM_DD`` folder on it, or ``sequences/NN`` of an odometry sequence (:data:`ODOMETRY_DAYS`)."""
    parts = path.parts
    for i in range(len(parts) - 1, -1, -1):
        match = _DRIVE.fullmatch(parts[i])
        if match or _DAY.fullmatch(parts[i]):
            day = match.group(1) if match else parts[i]
            return day if day.startswith("2011_") else None
        if i and parts[i - 1] == "sequences" and parts[i] in ODOMETRY_DAYS:
            return ODOMETRY_DAYS[parts[i]]
    return None


def check_scan_fits(scan: PurePath, kind: str, source: PurePath | None) -> None:
    """Refuse a calibration of another rig, or another KITTI day, than the scan's file layout names.

    KITTI raw and odometry scans are of one car (its cameras 2 and 3); KITTI-360's another
    (its cameras 0 and 1, a 1408x376 image). A raw calibration given for KITTI-360 scans, or
    the reverse, projects plausible-looking maps with the wrong geometry, which no statistic
    of the projected points reveals (docs/fill.md), so the layouts are compared. Each KITTI
    day has its own calibration too (2011_09_26's moves kitti-raw's 2011_09_30 scan by 10 px,
    median): a raw or odometry scan and calibration whose paths name two days are refused.

    Parameters
    ----------
    scan : path
        The scan file.
    kind : {"raw", "odometry", "kitti360"}
        The calibration's layout.
    source : path or None
        The calibration's file or folder, for the message.

    Raises
    ------
    CalibrationError
        Naming both rigs.
    """
    rig = rig_of_scan(scan)
    calib_rig = "kitti360" if kind == "kitti360" else "kitti"
    if rig is None or rig == calib_rig:
        if calib_rig == "kitti":
            _check_day(scan, source)
        return
    names = {"kitti360": "KITTI-360", "kitti": "KITTI raw/odometry"}
    layout = {"raw": "KITTI raw", "odometry": "KITTI odometry", "kitti360": "KITTI-360"}.get(kind, kind)
    raise CalibrationError(
        f"{scan} is a {names[rig]} scan (its folders say so), but the calibration {source or '(given as a matrix)'} "
        f"is a {layout} one, of the {names[calib_rig]} rig: it would project plausible-looking maps with the wrong "
        f"geometry; give the calibration of the {names[rig]} rig")


def _check_day(scan: PurePath, source: PurePath | None) -> None:
    day, calib_day = recording_day(scan), None if source is None else recording_day(source)
    if day is not None and calib_day is not None and day != calib_day:
        raise CalibrationError(
            f"{scan} was recorded on {day} (its folders say so), but the calibration {source} is of {calib_day}: each "
            f"KITTI day has its own calibration (another day's moves the points by about 10 px); give {day}'s")
