"""Camera calibration of LiDAR scans in the three layouts KITTI users hold.

One :class:`Calibration` is what projection needs: the 3 x 4 matrix taking a point of the
LiDAR frame (homogeneous) to the rectified image, and the image size.
:func:`read_calibration` reads it from

* a **KITTI raw** day folder (``calib_cam_to_cam.txt`` + ``calib_velo_to_cam.txt``):
  ``P_rect_0C · R_rect_00 · [R|T]_velo_to_cam``, image size ``S_rect_0C``;
* a **KITTI odometry** ``calib.txt`` (``P0..P3``, ``Tr``): ``PC · Tr``; the file holds no
  image size, so it is given (1241x376, 1226x370 or 1242x375 depending on the sequence);
* a **KITTI-360** calibration folder (``perspective.txt`` + ``calib_cam_to_velo.txt``):
  ``P_rect_0C · R_rect_00 · inv(T_cam0_to_velo)``, image size ``S_rect_0C``.

>>> calib = read_calibration("<KITTI raw>/2011_09_26")            # doctest: +SKIP
>>> calib.kind, calib.size
('raw', (1242, 375))
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..exceptions import CalibrationError, InvalidInputError

__all__ = ["CALIBRATION_LAYOUTS", "Calibration", "CalibrationError", "parse_size", "read_calibration"]

#: What :func:`read_calibration` accepts, for error messages.
CALIBRATION_LAYOUTS = (
    "a KITTI raw day folder (calib_cam_to_cam.txt + calib_velo_to_cam.txt), an odometry calib.txt "
    "(P0..P3 and Tr; give the image size), or a KITTI-360 calibration folder (perspective.txt + "
    "calib_cam_to_velo.txt)"
)
_RAW = ("calib_cam_to_cam.txt", "calib_velo_to_cam.txt")
_K360 = ("perspective.txt", "calib_cam_to_velo.txt")


@dataclass(frozen=True, eq=False)
class Calibration:
    """The projection of LiDAR points into one rectified camera image.

    Attributes
    ----------
    matrix : numpy.ndarray
        ``(3, 4)`` float64: a homogeneous LiDAR point ``X`` goes to ``matrix @ X = z (u, v, 1)``,
        ``z`` being the depth (metres) and ``(u, v)`` the pixel (column, row).
    size : tuple of int or None
        Image ``(width, height)`` in pixels; None when the calibration holds none
        (odometry) and none was given.
    kind : {"raw", "odometry", "kitti360"}
        The layout it was read from.
    source : pathlib.Path or None
        The file or folder it was read from.
    camera : int
        The camera index (2 or 3 for raw and odometry, 0 or 1 for KITTI-360).
    """

    matrix: np.ndarray
    size: tuple[int, int] | None
    kind: str
    source: Path | None = None
    camera: int = 2

    def __post_init__(self) -> None:
        m = np.asarray(self.matrix, dtype=np.float64)
        if m.shape != (3, 4) or not np.isfinite(m).all():
            raise CalibrationError(f"a projection matrix is 3 x 4 and finite, got shape {m.shape}")
        if abs(np.linalg.det(m[:, :3])) < 1e-12:
            raise CalibrationError(f"{self.source}: the projection matrix is singular (cannot back-project)")
        object.__setattr__(self, "matrix", m)

    def with_size(self, size: tuple[int, int] | None) -> Calibration:
        """The same projection with the image ``size`` ``(width, height)`` (None keeps this one's)."""
        if size is None:
            return self
        return Calibration(self.matrix, _check_size(size), self.kind, self.source, self.camera)

    def image_size(self) -> tuple[int, int]:
        """``(width, height)``; one clear error when the calibration holds none."""
        if self.size is None:
            raise CalibrationError(
                f"{self.source}: an odometry calib.txt holds no image size; give it (--size WxH, e.g. 1226x370 "
                "for odometry sequences 04-10, 1241x376 for 00-02, 1242x375 for 03)"
            )
        return self.size


def parse_size(text: str) -> tuple[int, int]:
    """``"1226x370"`` as ``(1226, 370)``; one clear error otherwise."""
    w, sep, h = str(text).lower().partition("x")
    try:
        size = (int(w), int(h)) if sep else None
    except ValueError:
        size = None
    if size is None:
        raise InvalidInputError(f"an image size is WIDTHxHEIGHT in pixels, e.g. 1226x370, got {text!r}")
    return _check_size(size)


def _check_size(size: tuple[int, int]) -> tuple[int, int]:
    w, h = (int(v) for v in size)
    if w < 1 or h < 1 or w > 1 << 15 or h > 1 << 15:
        raise InvalidInputError(f"image size {w}x{h} is not a camera image (1 to 32768 pixels a side)")
    return w, h


def _read_key_values(path: Path) -> dict[str, np.ndarray]:
    """``KEY: numbers`` lines of a KITTI calibration file (non-numeric lines, e.g. dates, skipped)."""
    try:
        text = path.read_text(encoding="ascii", errors="strict")
    except FileNotFoundError:
        raise CalibrationError(f"calibration file not found: {path}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise CalibrationError(f"cannot read calibration {path}: {exc}") from None
    out: dict[str, np.ndarray] = {}
    for line in text.splitlines():
        key, sep, values = line.partition(":")
        if not sep:
            continue
        try:
            out[key.strip()] = np.array([float(v) for v in values.split()], dtype=np.float64)
        except ValueError:
            continue  # calib_time: 09-Jan-2012 13:57:47
    return out


def _matrix(values: dict[str, np.ndarray], key: str, shape: tuple[int, int], path: Path) -> np.ndarray:
    """``values[key]`` reshaped; one error naming the file and key when absent or of the wrong length."""
    if key not in values:
        raise CalibrationError(f"{path} has no {key}; {CALIBRATION_LAYOUTS}")
    v = values[key]
    if v.size != shape[0] * shape[1] or not np.isfinite(v).all():
        raise CalibrationError(f"{path}: {key} holds {v.size} numbers, expected {shape[0] * shape[1]} finite ones")
    return v.reshape(shape)


def _homogeneous(rt: np.ndarray) -> np.ndarray:
    out = np.eye(4)
    out[: rt.shape[0], : rt.shape[1]] = rt
    return out


def _rect_size(values: dict[str, np.ndarray], camera: int, path: Path) -> tuple[int, int]:
    s = _matrix(values, f"S_rect_{camera:02d}", (1, 2), path)[0]
    return _check_size((round(s[0]), round(s[1])))


def _read_raw(folder: Path, camera: int) -> Calibration:
    c2c_path, v2c_path = folder / _RAW[0], folder / _RAW[1]
    c2c, v2c = _read_key_values(c2c_path), _read_key_values(v2c_path)
    p = _matrix(c2c, f"P_rect_{camera:02d}", (3, 4), c2c_path)
    r0 = _homogeneous(_matrix(c2c, "R_rect_00", (3, 3), c2c_path))
    velo = _homogeneous(np.hstack([_matrix(v2c, "R", (3, 3), v2c_path), _matrix(v2c, "T", (3, 1), v2c_path)]))
    return Calibration(p @ r0 @ velo, _rect_size(c2c, camera, c2c_path), "raw", folder, camera)


def _read_odometry(path: Path, camera: int) -> Calibration:
    values = _read_key_values(path)
    p = _matrix(values, f"P{camera}", (3, 4), path)
    tr = _homogeneous(_matrix(values, "Tr", (3, 4), path))
    return Calibration(p @ tr, None, "odometry", path, camera)


def _read_kitti360(folder: Path, camera: int) -> Calibration:
    persp_path, c2v_path = folder / _K360[0], folder / _K360[1]
    persp = _read_key_values(persp_path)
    p = _matrix(persp, f"P_rect_{camera:02d}", (3, 4), persp_path)
    r0 = _homogeneous(_matrix(persp, "R_rect_00", (3, 3), persp_path))
    try:
        numbers = np.array(c2v_path.read_text(encoding="ascii").split(), dtype=np.float64)
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise CalibrationError(f"cannot read calibration {c2v_path}: {exc}") from None
    if numbers.size != 12 or not np.isfinite(numbers).all():
        raise CalibrationError(f"{c2v_path} holds {numbers.size} numbers; T_cam0_to_velo is 12 (a 3 x 4 matrix)")
    cam_to_velo = _homogeneous(numbers.reshape(3, 4))
    return Calibration(p @ r0 @ np.linalg.inv(cam_to_velo), _rect_size(persp, camera, persp_path), "kitti360",
                       folder, camera)


def _locate(path: Path) -> tuple[str, Path]:
    """The layout and the folder (or file) of a calibration given as ``path``.

    Forgiving about where the user points: a file of a raw or KITTI-360 pair means its
    folder, a drive folder means its day folder, a KITTI-360 root means its ``calibration/``.
    """
    if path.is_file():
        if path.name in _RAW:
            return "raw", path.parent
        if path.name in _K360:
            return "kitti360", path.parent
        return "odometry", path
    for folder in (path, path.parent, path / "calibration"):
        if all((folder / name).is_file() for name in _RAW):
            return "raw", folder
        if all((folder / name).is_file() for name in _K360):
            return "kitti360", folder
    if (path / "calib.txt").is_file():
        return "odometry", path / "calib.txt"
    raise CalibrationError(f"{path} is not a calibration: expected {CALIBRATION_LAYOUTS}")


def read_calibration(
    path: str | os.PathLike, size: tuple[int, int] | None = None, camera: int | None = None,
) -> Calibration:
    """Read a calibration in any of the three layouts (see the module docstring).

    Parameters
    ----------
    path : path-like
        A KITTI raw day folder (or one of its two files, or a drive folder inside it), an
        odometry ``calib.txt`` (or its sequence folder), or a KITTI-360 calibration folder
        (or the KITTI-360 root holding ``calibration/``).
    size : (int, int), optional
        Image ``(width, height)``; needed for odometry, replaces the calibration's own otherwise.
    camera : int, optional
        The camera projected into: 2 (default) or 3 for raw and odometry, 0 (default) or 1
        for KITTI-360.

    Returns
    -------
    Calibration

    Raises
    ------
    FileNotFoundError
        If nothing is at ``path``.
    CalibrationError
        If the files are unreadable, lack a matrix, or ``camera`` is not one of the layout's.
    """
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"calibration not found: {p}; expected {CALIBRATION_LAYOUTS}")
    kind, where = _locate(p)
    cams = (0, 1) if kind == "kitti360" else (2, 3)
    cam = cams[0] if camera is None else camera
    if cam not in cams:
        raise CalibrationError(f"{where}: a {kind} calibration projects into camera {cams[0]} or {cams[1]}, "
                               f"not {camera!r}")
    reader = {"raw": _read_raw, "odometry": _read_odometry, "kitti360": _read_kitti360}[kind]
    return reader(where, cam).with_size(size)
