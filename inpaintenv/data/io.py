"""Reading and writing KITTI depth PNGs (uint16, metres = value / 256, 0 = no data).

Files are read and written as bytes by Python and decoded / encoded in memory by
OpenCV (``cv2.imdecode`` / ``cv2.imencode``): OpenCV is never given a path, so a file
name that is not valid UTF-8 (read by Python as surrogate escapes) is read like any
other. Before anything is decoded, the PNG header is checked -- the signature, the pixel
format and the declared size against :data:`MAX_FRAME_PIXELS` -- so a file that only
claims to be huge (a "PNG bomb") is refused in one line instead of allocating gigabytes.
"""

from __future__ import annotations

import os
import struct
import zipfile
import zlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from ..conventions import check_depth
from ..exceptions import DepthFormatError, FileTooLargeError, InvalidInputError
from ..files import MAX_FRAME_PIXELS, check_frame_pixels, open_regular, read_bytes, read_head, write_bytes_atomic

__all__ = [
    "KITTI_DEPTH_SCALE",
    "MAX_FRAME_PIXELS",
    "DepthFormatError",
    "FileTooLargeError",
    "PngHeader",
    "check_depth_header",
    "decode_depth_png",
    "depth_from_uint16",
    "encode_png",
    "load_array",
    "parse_png_header",
    "png_header",
    "read_depth_png",
    "read_depth_png_raw",
    "read_png",
    "write_depth_png",
    "write_png",
]

#: KITTI stores depth as uint16 PNG with metres = value / 256.
KITTI_DEPTH_SCALE: float = 256.0

_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
#: Bytes of a PNG that hold the signature and the IHDR chunk (length, type, 13 data bytes).
_HEADER_BYTES = 33
#: Leading bytes of formats OpenCV would decode although the file is named .png.
_OTHER_FORMATS = {b"II*\x00": "a TIFF", b"MM\x00*": "a TIFF", b"\xff\xd8\xff": "a JPEG", b"BM": "a BMP",
                  b"GIF8": "a GIF", b"RIFF": "a WebP (RIFF)", b"P5": "a PGM", b"\x93NUMPY": "a NumPy .npy"}
#: Bytes at the end of a ZIP searched for its end record (the record and the longest comment).
_EOCD_SEARCH = 22 + 65535
#: The largest ZIP directory of an ``.npz`` read (a few entries need a few hundred bytes).
_MAX_ZIP_DIRECTORY = 1 << 20
#: The largest ``.npy`` (member) read: :data:`MAX_FRAME_PIXELS` values of 16 bytes and a header.
_MAX_NPY_BYTES = 16 * MAX_FRAME_PIXELS + (1 << 16)
#: Bytes read at a time into an array being loaded.
_READ_CHUNK = 16 << 20
_COLOUR = {2: "3 channels (RGB)", 4: "2 channels (grey+alpha)", 6: "4 channels (RGBA)"}


@dataclass(frozen=True)
class PngHeader:
    """The fields of a PNG's IHDR chunk that matter for depth maps."""

    width: int
    height: int
    bit_depth: int
    color_type: int  # 0 = greyscale, 2 = RGB, 3 = palette, 4 = grey+alpha, 6 = RGBA


def parse_png_header(head: bytes, path: str | os.PathLike) -> PngHeader:
    """The IHDR fields of the first :data:`_HEADER_BYTES` bytes of a file (``path`` names it), or a DepthFormatError."""
    if head[:8] != _PNG_SIGNATURE:
        other = next((name for magic, name in _OTHER_FORMATS.items() if head.startswith(magic)), None)
        if other is not None:
            raise DepthFormatError(f"{path} is {other} file, not a PNG; KITTI depth is a 16-bit PNG")
        raise DepthFormatError(f"{path} is not a PNG file (no PNG signature; empty, or another format)")
    if len(head) < _HEADER_BYTES or head[12:16] != b"IHDR":
        raise DepthFormatError(f"{path} is truncated before the end of its PNG header")
    width, height, bit_depth, color_type = struct.unpack(">IIBB", head[16:26])
    return PngHeader(width, height, bit_depth, color_type)


def png_header(path: str | os.PathLike) -> PngHeader:
    """Read a PNG's size and pixel format from its first 33 bytes (no decoding).

    Raises
    ------
    DepthFormatError
        If the file is not a PNG (e.g. a TIFF named ``.png``) or is too short to hold
        the header.
    FileNotFoundError, IsADirectoryError, PermissionError, OSError
        If it cannot be read (as :func:`inpaintenv.files.read_bytes`).
    """
    path = Path(path)
    head, _ = read_head(path, _HEADER_BYTES, "depth PNG")
    return parse_png_header(head, path)


def check_depth_header(path: str | os.PathLike, header: PngHeader) -> None:
    """Refuse a PNG header that is not 16-bit single-channel or declares more than :data:`MAX_FRAME_PIXELS`.

    Raises
    ------
    DepthFormatError
        Naming the file and what it is (bit depth, channels, an empty image).
    FileTooLargeError
        A declared size beyond :data:`MAX_FRAME_PIXELS` (:func:`inpaintenv.files.check_frame_pixels`).
    """
    if header.color_type == 3:
        raise DepthFormatError(
            f"{path} is a {header.bit_depth}-bit palette (colour-indexed) PNG; KITTI depth is a single-channel "
            "16-bit PNG (metres = value / 256)"
        )
    if header.color_type != 0:
        kind = _COLOUR.get(header.color_type, f"colour type {header.color_type}")
        raise DepthFormatError(f"{path} has {kind}; a KITTI depth map is single-channel 16-bit")
    if header.bit_depth != 16:
        raise DepthFormatError(
            f"{path} is a {header.bit_depth}-bit PNG; KITTI depth must be 16-bit (metres = value / 256)"
        )
    _check_declared_size(path, header)


def _check_declared_size(path: str | os.PathLike, header: PngHeader) -> None:
    """Refuse a PNG declaring an empty image or more than :data:`MAX_FRAME_PIXELS` pixels, before decoding."""
    if header.width == 0 or header.height == 0:
        raise DepthFormatError(f"{path} declares an empty image ({header.width}x{header.height})")
    check_frame_pixels(header.height, header.width, str(path))


def _max_file_bytes(header: PngHeader) -> int:
    """Generous upper bound on the size of a 16-bit grey PNG of ``header``'s size (stored, uncompressed)."""
    return 3 * header.width * header.height + 4 * header.height + (1 << 20)


def read_depth_png(path: str | os.PathLike) -> np.ndarray:
    """Read a KITTI depth PNG as float32 metres.

    Parameters
    ----------
    path : path-like
        A 16-bit single-channel PNG of at most :data:`MAX_FRAME_PIXELS` pixels.

    Returns
    -------
    numpy.ndarray
        ``(H, W)`` float32 depth in metres, 0 where there is no measurement.

    Raises
    ------
    FileNotFoundError
        If the file does not exist.
    IsADirectoryError, PermissionError, OSError
        If the path is a folder, cannot be read for lack of permission, or another
        read error (each message names the path and the cause).
    UnsafeFileError
        A FIFO, device or socket: refused at once, never waited on.
    DepthFormatError
        If the file is not a PNG (checked by its signature, whatever its name), is
        truncated or corrupt, 8-bit, or has more than one channel.
    FileTooLargeError
        It declares more than :data:`MAX_FRAME_PIXELS` pixels, or is larger than its frame can need.
    """
    return depth_from_uint16(read_depth_png_raw(path))


def read_depth_png_raw(path: str | os.PathLike) -> np.ndarray:
    """Read a KITTI depth PNG as its stored uint16 values (metres * 256), validated.

    Cropping these before :func:`depth_from_uint16` converts only the kept pixels.
    Raises as :func:`read_depth_png`.
    """
    path = Path(path)
    header, data = _read_png_file(path, "depth PNG", check_depth_header, _max_file_bytes)
    return decode_depth_png(data, path, header)


def _read_png_file(
    path: Path, what: str, check_header: Callable[[Path, PngHeader], None], max_bytes: Callable[[PngHeader], int],
) -> tuple[PngHeader, bytes]:
    """A PNG file's checked header and its bytes, read in one open.

    The header is checked (``check_header``) before the rest of the file is read, so a
    file declaring a huge frame, or larger than its frame can need (``max_bytes``), is
    never read whole; a FIFO or device is refused unread (:func:`inpaintenv.files.open_regular`);
    read errors name the path and the cause.
    """
    head, _ = read_head(path, _HEADER_BYTES, what)
    header = parse_png_header(head, path)
    check_header(path, header)
    data = read_bytes(path, what, limit=max_bytes(header))
    if parse_png_header(data[:_HEADER_BYTES], path) != header:
        raise DepthFormatError(f"{path} changed while it was read; not decoded")
    return header, data


def decode_depth_png(data: bytes, name: str | os.PathLike, header: PngHeader | None = None) -> np.ndarray:
    """The stored uint16 values of the depth PNG held in ``data`` (a file's bytes), validated.

    The header is checked first (:func:`check_depth_header`) unless the caller passes
    the one it checked.

    Raises
    ------
    DepthFormatError
        As :func:`read_depth_png`, naming ``name``.
    """
    if header is None:
        header = parse_png_header(data[:_HEADER_BYTES], Path(name))
        check_depth_header(name, header)
    raw = _imdecode(data, name)
    if raw.ndim != 2:
        raise DepthFormatError(f"{name} has {raw.shape[2]} channels; a KITTI depth map is single-channel 16-bit")
    if raw.dtype != np.uint16:
        raise DepthFormatError(
            f"{name} is {raw.dtype} ({8 * raw.dtype.itemsize}-bit); KITTI depth must be a "
            "16-bit PNG (metres = value / 256)"
        )
    if raw.shape != (header.height, header.width):
        raise DepthFormatError(f"cannot decode {name}: its header says {header.width}x{header.height}, "
                               f"its pixels are {raw.shape[1]}x{raw.shape[0]}")
    return raw


def read_png(path: str | os.PathLike, what: str = "PNG") -> np.ndarray:
    """Any PNG (a hole mask, a colour image) decoded as OpenCV does, after the checks of a depth PNG's header.

    The signature and the declared size (at most :data:`MAX_FRAME_PIXELS`) are checked
    before decoding, the file is read by Python (any name works), and read errors name
    the path and the cause, as for :func:`read_depth_png`; the pixel format is the
    caller's to check.

    Returns
    -------
    numpy.ndarray
        ``(H, W)`` or ``(H, W, C)``, uint8 or uint16 (channels in OpenCV's BGR(A) order).

    Raises
    ------
    DepthFormatError
        Not a PNG (by its signature), or truncated/corrupt.
    FileTooLargeError
        A declared size beyond :data:`MAX_FRAME_PIXELS`, or a file larger than its frame can need.
    FileNotFoundError, IsADirectoryError, PermissionError, UnsafeFileError, OSError
        As :func:`inpaintenv.files.open_regular`.
    """
    path = Path(path)
    # Any pixel format: at most 8 bytes a pixel (16-bit RGBA) uncompressed, plus filter bytes.
    _, data = _read_png_file(path, what, _check_declared_size,
                             lambda h: 8 * h.width * h.height + 4 * h.height + (1 << 20))
    return _imdecode(data, path)


def _imdecode(data: bytes, name: str | os.PathLike) -> np.ndarray:
    """``data`` decoded by OpenCV as stored (IMREAD_UNCHANGED keeps 16 bits and the channel
    count, so callers can refuse bad files); an undecodable file is one error naming ``name``."""
    try:
        img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    except cv2.error as exc:
        raise DepthFormatError(f"cannot decode {name}: {str(exc).strip().splitlines()[-1]}") from None
    if img is None:
        raise DepthFormatError(f"cannot decode {name}: truncated or corrupt PNG")
    return img


def load_array(path: str | os.PathLike, what: str = "array", key: str | tuple[str, ...] | None = None) -> np.ndarray:
    """The array of an ``.npy`` file, or one array of an ``.npz``, its declared size checked before loading.

    The header's shape is checked against :data:`MAX_FRAME_PIXELS` values before any data
    is read (a 128-byte file can declare a terabyte); in an ``.npz`` the ZIP directory is
    checked too (its size, and each member's uncompressed size), so a small archive that
    expands to gigabytes is refused unread. Only arrays of numbers are read (no pickles,
    strings or records), and a file shorter than its header declares is truncated. A FIFO
    or device is refused at once (:func:`inpaintenv.files.open_regular`).

    Parameters
    ----------
    path : path-like
        An ``.npy`` or ``.npz`` file.
    what : str
        What the array is, for messages.
    key : str or tuple of str, optional
        The member of an ``.npz``. None: its only member. A tuple: its only member, else the
        first of these names it holds.

    Raises
    ------
    FileTooLargeError
        A declared size beyond :data:`MAX_FRAME_PIXELS` values, or a ZIP directory or member
        larger than such an array can need.
    DepthFormatError
        Not a NumPy file, not an array of numbers, truncated data, or an ``.npz`` without
        the array asked for (or with several arrays and no ``key``).
    FileNotFoundError, IsADirectoryError, PermissionError, UnsafeFileError, OSError
        As :func:`inpaintenv.files.open_regular`, naming the file.
    """
    path = Path(path)
    with os.fdopen(open_regular(path, what), "rb") as f:
        try:
            if f.read(4) != b"PK\x03\x04":
                f.seek(0)
                return _read_npy(f, str(path), os.fstat(f.fileno()).st_size)
            return _read_npz_member(f, path, what, key)
        except OSError as exc:
            if isinstance(exc, FileTooLargeError):
                raise
            raise OSError(f"cannot read {what} {path}: {exc.strerror or exc}") from None


def _check_zip_directory(f: Any, path: Path) -> None:
    """Refuse a ZIP whose directory is larger than an ``.npz`` of frames can need, before parsing it.

    :mod:`zipfile` keeps an object per directory entry; a hostile directory of millions of
    entries would take gigabytes, so its declared size is read from the end record first.
    """
    size = os.fstat(f.fileno()).st_size
    f.seek(max(0, size - _EOCD_SEARCH))
    tail = f.read()
    at = tail.rfind(b"PK\x05\x06")
    if at < 0 or len(tail) - at < 22:
        raise DepthFormatError(f"cannot read {path}: a damaged .npz (no ZIP directory at its end)")
    entries, directory = struct.unpack("<HI", tail[at + 10:at + 16])
    if tail[max(0, at - 20):at].startswith(b"PK\x06\x07") or directory > _MAX_ZIP_DIRECTORY:
        raise FileTooLargeError(f"{path} declares a ZIP directory of {entries:,} entries ({directory:,} bytes, or "
                                "ZIP64), more than an .npz of depth maps or masks can need; not read")
    f.seek(0)


def _choose_member(names: list[str], key: str | tuple[str, ...] | None, path: Path, what: str) -> str:
    """The member of an ``.npz`` holding ``names`` that :func:`load_array` reads for ``key``."""
    if isinstance(key, str):
        if key not in names:
            raise DepthFormatError(f"{path} has no array {key!r} (it holds {names})")
        return key
    if len(names) == 1:
        return names[0]
    found = next((k for k in key or () if k in names), None)
    if found is None:
        hint = f"name the {what} array {key[0]!r} or store one" if key else f"say which {what} to read"
        raise DepthFormatError(f"{path} holds the arrays {names}; {hint}")
    return found


def _read_npz_member(f: Any, path: Path, what: str, key: str | tuple[str, ...] | None) -> np.ndarray:
    """Array ``key`` of the ``.npz`` open as ``f``, each member's declared size checked first."""
    _check_zip_directory(f, path)
    try:
        with zipfile.ZipFile(f) as z:
            infos = z.infolist()
            for info in infos:
                if info.file_size > _MAX_NPY_BYTES:
                    raise FileTooLargeError(
                        f"member {info.filename!r} of {path} declares {info.file_size:,} bytes uncompressed, more "
                        f"than an array of {MAX_FRAME_PIXELS:,} values can need "
                        "(inpaintenv.files.MAX_FRAME_PIXELS); not read")
            names = [i.filename.removesuffix(".npy") for i in infos]
            member = _choose_member(names, key, path, what)
            info = infos[names.index(member)]
            with z.open(info) as m:
                return _read_npy(m, f"array {member!r} of {path}", info.file_size)
    except (zipfile.BadZipFile, zipfile.LargeZipFile, EOFError, NotImplementedError, zlib.error, struct.error,
            ValueError) as exc:
        if isinstance(exc, DepthFormatError):
            raise
        raise DepthFormatError(f"cannot read {path}: a damaged .npz ({exc})") from None


def _read_npy(f: Any, name: str, size: int) -> np.ndarray:
    """The array of the ``.npy`` stream ``f`` (at its start, ``size`` bytes long), its header checked first."""
    fmt = np.lib.format
    try:
        version = fmt.read_magic(f)
        readers = {(1, 0): fmt.read_array_header_1_0, (2, 0): fmt.read_array_header_2_0}
        if version not in readers:
            raise DepthFormatError(f"cannot read {name}: .npy format version {version[0]}.{version[1]} is not "
                                   "supported (save it with numpy.save)")
        shape, fortran, dtype = readers[version](f)
    except (ValueError, EOFError) as exc:
        if isinstance(exc, DepthFormatError):
            raise
        raise DepthFormatError(f"cannot read {name}: not a NumPy .npy file, or truncated before its data ({exc})") \
            from None
    count = int(np.prod(shape, dtype=object))
    if count > MAX_FRAME_PIXELS:
        raise FileTooLargeError(f"{name} declares an array of shape {shape} ({count:,} values), more than the "
                                f"{MAX_FRAME_PIXELS:,} a frame may have (inpaintenv.files.MAX_FRAME_PIXELS); not read")
    if dtype.kind not in "biufc" or dtype.fields is not None:
        raise DepthFormatError(f"{name} holds {dtype} values (not numbers); a depth map or mask holds numbers")
    nbytes = count * dtype.itemsize
    if size - f.tell() < nbytes:
        raise DepthFormatError(f"cannot read {name}: truncated ({max(0, size - f.tell())} of {nbytes} data bytes)")
    buf = bytearray(nbytes)  # read in place: no second copy of the array
    view, got = memoryview(buf), 0
    while got < nbytes and (n := f.readinto(view[got:got + _READ_CHUNK])):  # chunks: a zip member copies each
        got += n
    if got != nbytes:
        raise DepthFormatError(f"cannot read {name}: truncated ({got} of {nbytes} data bytes)")
    return np.frombuffer(buf, dtype=dtype).reshape(shape, order="F" if fortran else "C")


def depth_from_uint16(raw: np.ndarray) -> np.ndarray:
    """KITTI uint16 values to contiguous float32 metres in one pass (exact: /256 is a power of 2)."""
    return np.multiply(raw, np.float32(1.0 / KITTI_DEPTH_SCALE), dtype=np.float32)


def encode_png(image: np.ndarray, name: str | os.PathLike = "image") -> bytes:
    """``image`` (uint8 or uint16; grey, BGR or BGRA) as the bytes of a PNG file.

    Raises
    ------
    ValueError
        If OpenCV cannot encode it (the message names ``name``).
    """
    try:
        ok, buf = cv2.imencode(".png", image)
    except cv2.error as exc:
        raise InvalidInputError(f"cannot encode {name} as PNG: {str(exc).strip().splitlines()[-1]}") from None
    if not ok:
        raise InvalidInputError(f"cannot encode {name} as PNG")
    return buf.tobytes()


def write_png(path: str | os.PathLike, image: np.ndarray, what: str = "PNG") -> None:
    """Encode ``image`` as PNG in memory and write it to ``path`` whole or not at all.

    The write goes through :func:`inpaintenv.files.write_bytes_atomic` (a temporary file
    renamed over ``path``, never through a link); its folder is created. A failure names
    the file and the cause (``cannot write depth PNG out/x.png: No space left on device``).
    """
    write_bytes_atomic(path, encode_png(image, path), what)


def write_depth_png(path: str | os.PathLike, depth: np.ndarray) -> None:
    """Write float metres as a KITTI 16-bit depth PNG (values rounded to 1/256 m).

    Parameters
    ----------
    path : path-like
        Target file; must end in ``.png`` (the file is a PNG whatever its name; the
        suffix keeps names honest). Its folder is created.
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
        If the file cannot be written (the message names it and the cause, e.g. a full disk).
    """
    path = Path(path)
    if path.suffix.lower() != ".png":
        raise InvalidInputError(f"depth PNG path must end in .png, got {str(path)!r}")
    # The shared check refuses bool/complex/object, empty, NaN/inf, negative and
    # > 65535/256 m arrays with messages that name the problem.
    check_depth(depth, name="depth to write", ndim=(2,))
    # Scale in float64 so rounding to 1/256 m does not depend on float32 precision. No
    # overflow check needed: check_depth refused anything whose float32 value exceeds
    # 65535/256 m, so what passes is at most half a float32 step (8e-6 m) above it and
    # rounds to at most 65535.
    scaled = np.rint(np.asarray(depth, dtype=np.float64) * KITTI_DEPTH_SCALE)
    write_png(path, scaled.astype(np.uint16), "depth PNG")
