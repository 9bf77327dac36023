"""Reading and writing KITTI depth PNGs (uint16, metres = value / 256, 0 = no data).

Files are read and written as bytes by Python and decoded / encoded in memory by
OpenCV (``cv2.imdecode`` / ``cv2.imencode``): OpenCV is never given a path, so a file
name that is not valid UTF-8 (read by Python as surrogate escapes) is read like any
other. Before anything is decoded, the PNG header is checked -- the signature, the pixel
format and the declared size against :data:`MAX_FRAME_PIXELS` -- so a file that only
claims to be huge (a "PNG bomb") is refused in one line instead of allocating gigabytes.
"""

from __future__ import annotations

import errno
import os
import struct
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from ..conventions import MAX_FRAME_PIXELS, check_depth
from ..exceptions import DepthFormatError, FileTooLargeError, InvalidInputError

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
    "png_header",
    "read_depth_png",
    "read_depth_png_raw",
    "read_file_bytes",
    "read_png",
    "write_bytes",
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
_COLOUR = {2: "3 channels (RGB)", 4: "2 channels (grey+alpha)", 6: "4 channels (RGBA)"}


@dataclass(frozen=True)
class PngHeader:
    """The fields of a PNG's IHDR chunk that matter for depth maps."""

    width: int
    height: int
    bit_depth: int
    color_type: int  # 0 = greyscale, 2 = RGB, 3 = palette, 4 = grey+alpha, 6 = RGBA


def _clear_os_error(exc: OSError, path: Path, what: str) -> OSError:
    """``exc`` as an error of the same kind whose message names ``path`` and the cause."""
    if isinstance(exc, FileNotFoundError):
        return FileNotFoundError(f"{what} not found: {path}")
    if isinstance(exc, IsADirectoryError):
        return IsADirectoryError(f"{what} {path} is a folder, not a file")
    if isinstance(exc, PermissionError):
        return PermissionError(f"permission denied reading {what} {path}")
    if exc.errno == errno.ELOOP:
        return OSError(f"cannot read {what} {path}: a loop of symbolic links")
    return OSError(f"cannot read {what} {path}: {exc.strerror or exc}")


def read_file_bytes(path: str | os.PathLike, what: str = "file", limit: int | None = None) -> bytes:
    """The bytes of the file ``path``, or one OSError naming the path and the cause.

    Parameters
    ----------
    path : path-like
        The file (any name the OS accepts, including bytes that are not UTF-8).
    what : str
        What the file is, for messages (``"depth PNG"``).
    limit : int, optional
        Refuse a file larger than this many bytes (checked before reading).

    Raises
    ------
    FileNotFoundError
        Nothing is at ``path`` (or a link points nowhere).
    IsADirectoryError
        ``path`` is a folder.
    PermissionError
        The file cannot be read for lack of permission.
    OSError
        A loop of symbolic links, another read error, or a file larger than ``limit``.
    """
    path = Path(path)
    try:
        with open(path, "rb") as f:
            return _read_at_most(f, path, what, limit)
    except FileTooLargeError:
        raise
    except OSError as exc:
        raise _clear_os_error(exc, path, what) from None


def _read_at_most(f: Any, path: Path, what: str, limit: int | None) -> bytes:
    """The rest of the open file ``f``, refused (OSError) when the file is larger than ``limit`` bytes."""
    size = os.fstat(f.fileno()).st_size
    if limit is not None and size > limit:
        raise FileTooLargeError(f"{what} {path} is {size:,} bytes, more than the {limit:,} it can need; not read")
    return f.read()


def _parse_header(head: bytes, path: Path) -> PngHeader:
    """The IHDR fields of the first :data:`_HEADER_BYTES` bytes of a file, or a DepthFormatError."""
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
        If it cannot be read (as :func:`read_file_bytes`).
    """
    path = Path(path)
    try:
        with open(path, "rb") as f:
            head = f.read(_HEADER_BYTES)
    except OSError as exc:
        raise _clear_os_error(exc, path, "depth PNG") from None
    return _parse_header(head, path)


def check_depth_header(path: str | os.PathLike, header: PngHeader) -> None:
    """Refuse a PNG header that is not 16-bit single-channel or declares more than :data:`MAX_FRAME_PIXELS`.

    Raises
    ------
    DepthFormatError
        Naming the file and what it is (bit depth, channels, declared size).
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
    if header.width * header.height > MAX_FRAME_PIXELS:
        raise DepthFormatError(
            f"{path} declares {header.width}x{header.height} pixels (W x H), more than the "
            f"{MAX_FRAME_PIXELS:,} a depth frame may have (inpaintenv.conventions.MAX_FRAME_PIXELS); not decoded"
        )


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
    DepthFormatError
        If the file is not a PNG (checked by its signature, whatever its name), is
        truncated or corrupt, 8-bit, has more than one channel, or declares more than
        :data:`MAX_FRAME_PIXELS` pixels.
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
    never read whole; read errors name the path and the cause.
    """
    try:
        with open(path, "rb") as f:
            head = f.read(_HEADER_BYTES)
            header = _parse_header(head, path)
            check_header(path, header)
            return header, head + _read_at_most(f, path, what, max_bytes(header))
    except FileTooLargeError:
        raise
    except OSError as exc:
        raise _clear_os_error(exc, path, what) from None


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
        header = _parse_header(data[:_HEADER_BYTES], Path(name))
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
        Not a PNG (by its signature), a declared size beyond the limit, or truncated/corrupt.
    FileNotFoundError, IsADirectoryError, PermissionError, OSError
        As :func:`read_file_bytes`.
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


def load_array(path: str | os.PathLike, what: str = "array", key: str | None = None) -> np.ndarray:
    """The array of an ``.npy`` file, or array ``key`` of an ``.npz``, its header checked before loading.

    The header's shape is checked against :data:`MAX_FRAME_PIXELS` elements before any data
    is read (a 128-byte file can declare a terabyte), object arrays are refused (they
    would need pickles), and a file shorter than its header declares is truncated.

    Parameters
    ----------
    path : path-like
        An ``.npy`` or ``.npz`` file.
    what : str
        What the array is, for messages.
    key : str, optional
        The member of an ``.npz``; its only member when None.

    Raises
    ------
    DepthFormatError
        Not a NumPy file, a declared size beyond the limit, an object dtype, truncated data,
        or an ``.npz`` without ``key`` (or with several arrays and no ``key``).
    FileNotFoundError, IsADirectoryError, PermissionError, OSError
        As :func:`read_file_bytes`.
    """
    import zipfile

    path = Path(path)
    try:
        with open(path, "rb") as f:
            if f.read(4) != b"PK\x03\x04":
                f.seek(0)
                return _read_npy(f, str(path))
            f.seek(0)
            try:
                with zipfile.ZipFile(f) as z:
                    names = [n.removesuffix(".npy") for n in z.namelist()]
                    if key is None and len(names) != 1:
                        raise DepthFormatError(f"{path} holds the arrays {names}; say which {what} to read")
                    member = names[0] if key is None else key
                    if member not in names:
                        raise DepthFormatError(f"{path} has no array {member!r} (it holds {names})")
                    with z.open(member + ".npy") as m:
                        return _read_npy(m, f"array {member!r} of {path}")
            except (zipfile.BadZipFile, EOFError) as exc:
                raise DepthFormatError(f"cannot read {path}: a damaged .npz ({exc})") from None
    except OSError as exc:
        raise _clear_os_error(exc, path, what) from None


def _read_npy(f: Any, name: str) -> np.ndarray:
    """The array of the ``.npy`` stream ``f`` (at its start), its header checked first."""
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
        raise DepthFormatError(f"{name} declares an array of shape {shape} ({count:,} values), more than the "
                               f"{MAX_FRAME_PIXELS:,} a frame may have (inpaintenv.conventions.MAX_FRAME_PIXELS); not read")
    if dtype.hasobject:
        raise DepthFormatError(f"{name} holds Python objects (dtype {dtype}); a depth file holds numbers")
    data = f.read(count * dtype.itemsize)
    if len(data) != count * dtype.itemsize:
        raise DepthFormatError(f"cannot read {name}: truncated ({len(data)} of {count * dtype.itemsize} data bytes)")
    arr = np.frombuffer(data, dtype=dtype)
    return arr.reshape(shape, order="F" if fortran else "C").copy()


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


def write_bytes(path: str | os.PathLike, data: bytes, what: str = "file") -> None:
    """Write ``data`` to ``path`` (its folder created), or one OSError naming the file and the cause.

    The message says, e.g., ``cannot write depth PNG out/x.png: No space left on device``;
    a partly written file is removed.

    Raises
    ------
    PermissionError
        Permission denied (or a read-only file system).
    OSError
        Any other failure, e.g. a full disk.
    """
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path, "wb") as f:
            f.write(data)
    except OSError as exc:
        if path.is_file() and not isinstance(exc, (FileExistsError, IsADirectoryError)):
            path.unlink(missing_ok=True)  # a truncated file would read as a corrupt frame later
        cause = exc.strerror or str(exc)
        where = "" if exc.filename in (None, str(path)) else f" ({exc.filename})"
        if isinstance(exc, PermissionError) or exc.errno == errno.EROFS:
            raise PermissionError(f"cannot write {what} {path}: {cause}{where}") from None
        raise OSError(f"cannot write {what} {path}: {cause}{where}") from None


def write_png(path: str | os.PathLike, image: np.ndarray, what: str = "PNG") -> None:
    """Encode ``image`` as PNG in memory and write it to ``path`` (see :func:`write_bytes`)."""
    write_bytes(path, encode_png(image, path), what)


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
