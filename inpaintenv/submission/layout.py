"""Where exported inputs, hole masks and predictions live, and how they are encoded.

Relative paths follow KITTI's depth-completion layout, one tree per protocol and seed::

    <protocol>/seed_<s>/<split>/<drive>/proj_depth/velodyne_raw/<camera>/<frame>.png   occluded input
    <protocol>/seed_<s>/<split>/<drive>/proj_depth/hole/<camera>/<frame>.png           hole mask

so ``<export>/<protocol>/seed_<s>`` reads as a KITTI root for tools that load
``proj_depth/velodyne_raw`` inputs. A prediction goes to ``<predictions>/<input's relative
path>``. The protocol folder ties a prediction to the masks it was made for: predictions
made for another protocol are not found under this manifest's paths.
"""

from __future__ import annotations

import hashlib
import os
import re
import stat
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np

from ..data.io import parse_png_header
from ..exceptions import DepthFormatError, FileTooLargeError, UnsafeFileError
from ..files import MAX_FRAME_PIXELS, open_regular, read_bytes  # a manifest may declare no larger frame than a depth PNG may

__all__ = [
    "DEPTH_ENCODING", "HOLE_ENCODING", "HOLE_FOLDER", "HOLE_VALUE", "INPUT_FOLDER", "MAX_FRAME_PIXELS",
    "UnsafeFileError", "array_sha256", "decode_prediction", "file_sha256", "frame_parts", "hole_bits_sha256", "input_key", "is_inside",
    "is_safe_relative", "max_png_bytes", "png_declared_size", "read_inside", "relative_paths",
]

#: Folder of the occluded inputs (where KITTI keeps a method's sparse input).
INPUT_FOLDER = "velodyne_raw"
#: Folder of the hole masks.
HOLE_FOLDER = "hole"
#: Value of a hole pixel in the 8-bit mask PNG (0 elsewhere); white = fill, for viewers.
HOLE_VALUE = 255
DEPTH_ENCODING = "16-bit single-channel PNG, metres = value / 256, 0 = hole or no measurement"
HOLE_ENCODING = f"8-bit single-channel PNG, {HOLE_VALUE} = hole (pixels to fill), 0 = not"

_SAFE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text).strip("._") or "frame"


def frame_parts(frame_ids: Sequence[str], drives: Sequence[str]) -> list[tuple[str, str, str]]:
    """``(drive, camera, frame)`` folder names of every frame, distinct per frame.

    KITTI and SyntheticStreets ids are ``"<drive>/<camera>/<frame>"`` and keep their
    names; other ids (a custom dataset) become ``(<drive>, "image_02", <position>)``.
    """
    parts = []
    for i, (fid, drive) in enumerate(zip(frame_ids, drives)):
        pieces = str(fid).split("/")
        if len(pieces) == 3 and all(_SAFE.match(p) for p in pieces):
            parts.append((pieces[0], pieces[1], pieces[2]))
        else:
            parts.append((_slug(str(drive)), "image_02", f"{i:010d}"))
    if len(set(parts)) != len(parts):
        # Ids that collide as folder names: number the frames instead.
        parts = [(_slug(str(d)), "image_02", f"{i:010d}") for i, d in enumerate(drives)]
    return parts


def relative_paths(protocol: str, seed: int, split: str, parts: tuple[str, str, str]) -> tuple[str, str]:
    """``(input, hole)`` relative paths (POSIX) of one frame under ``(protocol, seed)``."""
    drive, camera, frame = parts
    base = f"{protocol}/seed_{seed}/{split}/{drive}/proj_depth"
    return f"{base}/{INPUT_FOLDER}/{camera}/{frame}.png", f"{base}/{HOLE_FOLDER}/{camera}/{frame}.png"


def file_sha256(path: str | os.PathLike, what: str = "file", *, follow_links: bool = True) -> str:
    """sha256 of a regular file's bytes (a FIFO or device is refused, see :func:`inpaintenv.files.open_regular`)."""
    h = hashlib.sha256()
    fd = open_regular(path, what, follow_links=follow_links)
    with os.fdopen(fd, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def array_sha256(array: np.ndarray) -> str:
    """sha256 of an array's bytes in C order (its dtype and shape are recorded beside it)."""
    return hashlib.sha256(np.ascontiguousarray(array).tobytes()).hexdigest()


def hole_bits_sha256(hole: np.ndarray) -> str:
    """sha256 of a boolean mask packed to bits: what ``score`` recomputes to check the masks."""
    return hashlib.sha256(np.packbits(np.asarray(hole, dtype=bool)).tobytes()).hexdigest()


def input_key(x: np.ndarray) -> str:
    """sha256 of one corrupted input as :func:`inpaintenv.evaluate.evaluate` builds it.

    ``x`` is the float32 ``(H, W)`` method input (:func:`inpaintenv.data.method_input`: the
    ground truth with NaN in the hole, or a scan with NaN wherever it is to fill). ``score``
    finds the prediction of an input by this key, so the frame and seed need not be passed along.
    """
    return array_sha256(np.asarray(x, dtype=np.float32))


def is_inside(path: Path, folder: Path) -> bool:
    """Whether ``path`` is ``folder`` or lies under it (both resolved)."""
    try:
        path.resolve().relative_to(folder.resolve())
    except ValueError:
        return False
    return True


def max_png_bytes(shape: Sequence[int]) -> int:
    """Most bytes a 16-bit single-channel PNG of ``shape`` (H, W) can need, with a wide margin.

    A PNG stored without compression holds 2 bytes per pixel and 1 filter byte per row,
    plus a few bytes per 64 KiB block and per chunk; 3 bytes per pixel, 4 per row and
    1 MiB for ancillary chunks cover any encoder's output. A larger file is refused
    unread (a sparse file can claim gigabytes on a small disk).
    """
    h, w = int(shape[0]), int(shape[1])
    return 3 * h * w + 4 * h + (1 << 20)


def is_safe_relative(rel: str) -> bool:
    """Whether ``rel`` is a relative POSIX path that stays below its folder (no ``..``, not absolute)."""
    if not isinstance(rel, str) or not rel or rel.startswith("/") or "\\" in rel or "\0" in rel:
        return False
    parts = rel.split("/")
    return all(p not in ("", ".", "..") for p in parts) and not re.match(r"^[A-Za-z]:", rel)


def read_inside(folder: Path, rel: str, limit: int) -> bytes:
    """The bytes of the regular file ``folder/rel``, refusing anything that could lead elsewhere.

    ``rel`` must be a relative path below ``folder``; the file must not be a symbolic
    link, its resolved path must lie in ``folder`` (so no folder on the way is a link out
    of it), it must be a regular file (not a FIFO or device) and at most ``limit`` bytes.

    Raises
    ------
    UnsafeFileError
        Naming ``rel`` and the reason.
    FileNotFoundError
        If there is no file at ``rel``.
    """
    if not is_safe_relative(rel):
        raise UnsafeFileError(f"{rel} is not a relative path inside {folder}")
    path = folder / rel
    try:
        info = os.lstat(path)
    except FileNotFoundError:
        raise FileNotFoundError(f"{rel} is missing under {folder}") from None
    if stat.S_ISLNK(info.st_mode):
        raise UnsafeFileError(f"{rel} is a symbolic link (only regular files inside {folder} are read)")
    if not is_inside(path, folder):
        raise UnsafeFileError(f"{rel} lies outside {folder} through a linked folder (only files inside it are read)")
    try:  # no link followed, no FIFO waited on, the size checked before anything is read
        return read_bytes(path, "prediction", limit=limit, follow_links=False)
    except FileTooLargeError:
        size = os.lstat(path).st_size
        raise UnsafeFileError(f"prediction {path} is {size:,} bytes, more than the {limit:,} a 16-bit PNG of the frame "
                              "can need; not read") from None


def png_declared_size(data: bytes) -> tuple[int, int] | None:
    """``(height, width)`` a PNG's header declares, or None if ``data`` does not begin with a PNG header."""
    try:
        header = parse_png_header(data[:64], "prediction")
    except DepthFormatError:
        return None
    return header.height, header.width


def decode_prediction(data: bytes, name: str, shape: tuple[int, int]) -> np.ndarray | str:
    """The stored uint16 values of a prediction PNG, or what is wrong with it (one phrase).

    The header's declared size is checked against ``shape`` before anything is decoded:
    a small file can declare gigabytes of pixels (a PNG bomb), and OpenCV would allocate
    them, or decode a TIFF or JPEG named ``.png``.
    """
    declared = png_declared_size(data)
    if declared is None:
        return f"{name} is not a readable PNG"
    if declared != tuple(shape):
        return (f"{name} declares {declared[1]}x{declared[0]}, the input is {shape[1]}x{shape[0]} (W x H); "
                "not decoded")
    try:
        raw = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    except cv2.error:
        raw = None
    if raw is None:
        return f"{name} is not a readable PNG"
    if raw.ndim != 2:
        return f"{name} has {raw.shape[2]} channels (a depth map is single-channel)"
    if raw.dtype != np.uint16:
        return f"{name} is {8 * raw.dtype.itemsize}-bit (depth is a 16-bit PNG, metres × 256)"
    if raw.shape != tuple(shape):
        return f"{name} is {raw.shape[1]}x{raw.shape[0]}, the input {shape[1]}x{shape[0]} (W x H)"
    return raw
