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
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..exceptions import CalibrationError, FileTooLargeError, InvalidInputError, UnsafeFileError
from ..files import MAX_TEXT_BYTES, check_frame_pixels, open_regular, read_text
from ..values.calibration import MAX_CONDITION, check_projection, check_rotation

__all__ = ["CALIBRATION_LAYOUTS", "MAX_CONDITION", "Calibration", "CalibrationError", "check_size", "parse_size",
           "read_calibration"]

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
        where = f"{self.source}: " if self.source is not None else ""
        m = check_projection(self.matrix, where)  # finite, invertible, right-handed (inpaintenv.values.calibration)
        object.__setattr__(self, "matrix", m)

    def with_size(self, size: tuple[int, int] | None) -> Calibration:
        """The same projection with the image ``size`` ``(width, height)`` (None keeps this one's)."""
        if size is None:
            return self
        return Calibration(self.matrix, check_size(size), self.kind, self.source, self.camera)

    def image_size(self) -> tuple[int, int]:
        """``(width, height)``; one clear error when the calibration holds none."""
        if self.size is None:
            raise CalibrationError(
                f"{self.source}: an odometry calib.txt holds no image size; give it (--size WxH, e.g. 1226x370 "
                "for odometry sequences 04-10, 1241x376 for 00-02, 1242x375 for 03)"
            )
        return self.size


def parse_size(text: str) -> tuple[int, int]:
    """``"1226x370"`` as ``(1226, 370)``; one clear error otherwise (see :func:`check_size`)."""
    w, sep, h = str(text).lower().partition("x")
    try:
        size = (int(w), int(h)) if sep else None
    except ValueError:
        size = None
    if size is None:
        raise InvalidInputError(f"an image size is WIDTHxHEIGHT in pixels, e.g. 1226x370, got {text!r}")
    return check_size(size)


def check_size(size: tuple[int, int], what: str = "image size") -> tuple[int, int]:
    """``(width, height)`` of a camera image as ints, or one clear error.

    Raises
    ------
    InvalidInputError
        A side below 1 or above 32768 pixels.
    FileTooLargeError
        More than :data:`~inpaintenv.files.MAX_FRAME_PIXELS` pixels
        (:func:`inpaintenv.files.check_frame_pixels`): the projected map is allocated whole.
    """
    w, h = (int(v) for v in size)
    if w < 1 or h < 1 or w > 1 << 15 or h > 1 << 15:
        raise InvalidInputError(f"{what} {w}x{h} is not a camera image (1 to 32768 pixels a side)")
    check_frame_pixels(h, w, f"{what} {w}x{h}")
    return w, h


#: A number of a calibration file: decimal, as KITTI writes them (no hex, nan, inf or ``_``).
_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")

#: What a ``KEY: numbers`` line of a calibration file holds: its line number and its numbers,
#: or the first token that is not a decimal number.
_Entry = tuple[int, "np.ndarray | str"]


def _read_text(path: Path) -> str:
    """The ASCII text of a calibration file through the safe file layer; one CalibrationError otherwise."""
    try:
        return read_text(path, "calibration file", limit=MAX_TEXT_BYTES, encoding="ascii")
    except FileNotFoundError:
        raise CalibrationError(f"calibration file not found: {path}") from None
    except FileTooLargeError:
        raise
    except (OSError, UnsafeFileError) as exc:
        raise CalibrationError(str(exc)) from None


def _numbers(tokens: list[str]) -> np.ndarray | str:
    """``tokens`` as float64, or the first one that is not a decimal number."""
    bad = next((t for t in tokens if not _NUMBER.fullmatch(t)), None)
    return np.array([float(t) for t in tokens], dtype=np.float64) if bad is None else bad


def _read_key_values(path: Path) -> dict[str, list[_Entry]]:
    """Every ``KEY: values`` line of a KITTI calibration file, by key (line number, numbers or the bad token).

    Lines that are not numbers (``calib_time: 09-Jan-2012 13:57:47``) are kept as such and
    refused only when their key is read (:func:`_matrix`), so a hex number or a typo in a
    matrix names its file and line instead of being dropped.
    """
    out: dict[str, list[_Entry]] = {}
    for number, line in enumerate(_read_text(path).splitlines(), start=1):
        key, sep, values = line.partition(":")
        if sep:
            out.setdefault(key.strip(), []).append((number, _numbers(values.split())))
    return out


def _matrix(values: dict[str, list[_Entry]], key: str, shape: tuple[int, int], path: Path) -> np.ndarray:
    """``values[key]`` reshaped; one error naming the file (and line) when absent, repeated, not numbers or of the wrong length."""
    if key not in values:
        raise CalibrationError(f"{path} has no {key}; {CALIBRATION_LAYOUTS}")
    entries = values[key]
    if len(entries) > 1:
        raise CalibrationError(f"{path}: {key} is given on lines {', '.join(str(n) for n, _ in entries)}; give it once")
    line, v = entries[0]
    if isinstance(v, str):
        raise CalibrationError(f"{path} line {line}: {key} holds {v!r}, not a decimal number")
    if v.size != shape[0] * shape[1]:
        raise CalibrationError(f"{path}: {key} holds {v.size} numbers, expected {shape[0] * shape[1]}")
    if not np.isfinite(v).all():  # a decimal beyond float64's range (1e400) reads as inf
        raise CalibrationError(f"{path} line {line}: {key} holds a number beyond any float (it reads as infinite)")
    return v.reshape(shape)


def _rotation(values: dict[str, list[_Entry]], key: str, path: Path, shape: tuple[int, int] = (3, 3)) -> np.ndarray:
    """``values[key]`` as :func:`_matrix` gives it, its 3 x 3 part checked to be a rotation."""
    m = _matrix(values, key, shape, path)
    check_rotation(m[:, :3], f"{path}: {key}")
    return m


def _homogeneous(rt: np.ndarray) -> np.ndarray:
    out = np.eye(4)
    out[: rt.shape[0], : rt.shape[1]] = rt
    return out


def _rect_size(values: dict[str, np.ndarray], camera: int, path: Path) -> tuple[int, int]:
    key = f"S_rect_{camera:02d}"
    s = _matrix(values, key, (1, 2), path)[0]
    if not (s == np.round(s)).all():
        raise CalibrationError(f"{path}: {key} is {s[0]:g} x {s[1]:g}; an image size is whole pixels")
    return check_size((round(s[0]), round(s[1])), f"{path}: {key}")


def _read_raw(folder: Path, camera: int) -> Calibration:
    c2c_path, v2c_path = folder / _RAW[0], folder / _RAW[1]
    c2c, v2c = _read_key_values(c2c_path), _read_key_values(v2c_path)
    p = _matrix(c2c, f"P_rect_{camera:02d}", (3, 4), c2c_path)
    r0 = _homogeneous(_rotation(c2c, "R_rect_00", c2c_path))
    velo = _homogeneous(np.hstack([_rotation(v2c, "R", v2c_path), _matrix(v2c, "T", (3, 1), v2c_path)]))
    return Calibration(p @ r0 @ velo, _rect_size(c2c, camera, c2c_path), "raw", folder, camera)


def _read_odometry(path: Path, camera: int) -> Calibration:
    values = _read_key_values(path)
    p = _matrix(values, f"P{camera}", (3, 4), path)
    tr = _homogeneous(_rotation(values, "Tr", path, (3, 4)))
    return Calibration(p @ tr, None, "odometry", path, camera)


def _read_kitti360(folder: Path, camera: int) -> Calibration:
    persp_path, c2v_path = folder / _K360[0], folder / _K360[1]
    persp = _read_key_values(persp_path)
    p = _matrix(persp, f"P_rect_{camera:02d}", (3, 4), persp_path)
    r0 = _homogeneous(_rotation(persp, "R_rect_00", persp_path))
    rows = [(n, _numbers(line.split())) for n, line in enumerate(_read_text(c2v_path).splitlines(), start=1)]
    bad = next(((n, v) for n, v in rows if isinstance(v, str)), None)
    if bad is not None:
        raise CalibrationError(f"{c2v_path} line {bad[0]}: {bad[1]!r} is not a decimal number")
    numbers = np.concatenate([v for _, v in rows] or [np.zeros(0)])
    if numbers.size != 12 or not np.isfinite(numbers).all():
        raise CalibrationError(f"{c2v_path} holds {numbers.size} numbers; T_cam0_to_velo is 12 (a 3 x 4 matrix)")
    try:
        velo_to_cam = np.linalg.inv(_homogeneous(numbers.reshape(3, 4)))
    except np.linalg.LinAlgError:
        raise CalibrationError(f"{c2v_path}: T_cam0_to_velo is singular (not a rigid motion); cannot invert it") \
            from None
    check_rotation(numbers.reshape(3, 4)[:, :3], f"{c2v_path}: T_cam0_to_velo")
    with np.errstate(all="ignore"):
        matrix = p @ r0 @ velo_to_cam
    return Calibration(matrix, _rect_size(persp, camera, persp_path), "kitti360", folder, camera)


def _is_file_like(path: Path) -> bool:
    """Something other than a folder is at ``path`` (a FIFO named like a calibration is found, then refused when read)."""
    return path.exists() and not path.is_dir()


def _check_regular(path: Path) -> None:
    """Refuse a calibration path that is a FIFO, device or socket, in one CalibrationError."""
    try:
        os.close(open_regular(path, "calibration file"))
    except FileNotFoundError:
        raise CalibrationError(f"calibration file not found: {path}") from None
    except (OSError, UnsafeFileError) as exc:
        raise CalibrationError(str(exc)) from None


def _locate(path: Path) -> tuple[str, Path]:
    """The layout and the folder (or file) of a calibration given as ``path``.

    Forgiving about where the user points: a file of a raw or KITTI-360 pair means its
    folder, a drive folder means its day folder, a KITTI-360 root means its ``calibration/``.
    """
    if not path.is_dir():
        _check_regular(path)  # a FIFO or device is refused here, never waited on
        if path.name in _RAW:
            return "raw", path.parent
        if path.name in _K360:
            return "kitti360", path.parent
        return "odometry", path
    for folder in (path, path.parent, path / "calibration"):
        raw, k360 = (all(_is_file_like(folder / name) for name in names) for names in (_RAW, _K360))
        if raw and k360:  # which one the user meant is theirs to say
            raise CalibrationError(f"{folder} holds both a KITTI raw ({' + '.join(_RAW)}) and a KITTI-360 "
                                   f"({' + '.join(_K360)}) calibration; give one of their files")
        if raw or k360:
            return ("raw" if raw else "kitti360"), folder
    if _is_file_like(path / "calib.txt"):
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
        If the files are unreadable (a FIFO or device is refused at once), lack a matrix,
        hold a value that is not a decimal number (its file and line named), give a singular,
        badly conditioned (:data:`MAX_CONDITION`) or left-handed projection
        (:mod:`inpaintenv.values.calibration`), or ``camera`` is not one of the layout's.
    FileTooLargeError
        A file larger than ``inpaintenv.files.MAX_TEXT_BYTES``, or an image size beyond
        ``inpaintenv.files.MAX_FRAME_PIXELS``.
    """
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"calibration not found: {p}; expected {CALIBRATION_LAYOUTS}")
    kind, where = _locate(p)
    cams = (0, 1) if kind == "kitti360" else (2, 3)
    cam = cams[0] if camera is None else camera
    if cam not in cams:
        layout = {"raw": "KITTI raw", "odometry": "KITTI odometry", "kitti360": "KITTI-360"}[kind]
        raise CalibrationError(f"{where}: a {layout} calibration projects into camera {cams[0]} or {cams[1]}, "
                               f"not {camera!r}")
    reader = {"raw": _read_raw, "odometry": _read_odometry, "kitti360": _read_kitti360}[kind]
    return reader(where, cam).with_size(size)
