"""Reading files: regular files only, size checked before anything is read.

Every read of the package opens its file here. ``open`` is non-blocking, so a FIFO or a
device named like a data file is refused at once instead of hanging the command; the
size is taken from the open file (``fstat``), so it cannot change between check and read.
Files inside a folder the command owns (a run folder, ``--out``) are opened without
following a link at their last component (``follow_links=False``): a link planted there
is refused rather than read.
"""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path

from ..exceptions import FileTooLargeError, UnsafeFileError

__all__ = ["describe_kind", "open_regular", "read_bytes", "read_head", "read_text"]


def describe_kind(mode: int) -> str:
    """What a non-regular file is, in words (``"a FIFO"``, ``"a folder"``, ...)."""
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    if stat.S_ISLNK(mode):
        return "a symbolic link"
    return "not a regular file"


def _os_error(exc: OSError, path: Path, what: str, follow_links: bool) -> OSError:
    """``exc`` as an error of the same kind whose message names ``path``, ``what`` and the cause."""
    if isinstance(exc, FileNotFoundError):
        return FileNotFoundError(f"{what} not found: {path}")
    if isinstance(exc, IsADirectoryError):
        return IsADirectoryError(f"{what} {path} is a folder, not a file")
    if isinstance(exc, PermissionError):
        return PermissionError(f"permission denied reading {what} {path}")
    if exc.errno == errno.ELOOP:
        if not follow_links:
            return UnsafeFileError(f"{what} {path} is a symbolic link; files of a folder the command owns are not "
                                   "read through links")
        return OSError(f"cannot read {what} {path}: a loop of symbolic links")
    if exc.errno == errno.ENAMETOOLONG:
        return OSError(f"cannot read {what} {path}: its name is too long for the file system")
    return OSError(f"cannot read {what} {path}: {exc.strerror or exc}")


def open_regular(path: str | os.PathLike, what: str = "file", *, follow_links: bool = True) -> int:
    """Open ``path`` for reading and return its descriptor, or refuse anything but a regular file.

    Parameters
    ----------
    path : path-like
        Any name the OS accepts (bytes that are not UTF-8 included).
    what : str
        What the file is, for messages (``"depth PNG"``).
    follow_links : bool
        False for files of a folder the command owns: a symbolic link there is refused.

    Returns
    -------
    int
        An open file descriptor (the caller closes it).

    Raises
    ------
    FileNotFoundError, IsADirectoryError, PermissionError, OSError
        Naming ``path`` and the cause.
    UnsafeFileError
        A FIFO, device or socket, or (``follow_links=False``) a symbolic link.
    """
    path = Path(path)
    flags = os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0)
    if not follow_links:
        flags |= os.O_NOFOLLOW
    try:
        fd = os.open(path, flags)
    except OSError as exc:
        raise _os_error(exc, path, what, follow_links) from None
    mode = os.fstat(fd).st_mode
    if not stat.S_ISREG(mode):
        os.close(fd)
        if stat.S_ISDIR(mode):
            raise IsADirectoryError(f"{what} {path} is a folder, not a file")
        raise UnsafeFileError(f"{what} {path} is {describe_kind(mode)}, not a regular file; not read")
    return fd


def read_bytes(path: str | os.PathLike, what: str = "file", *, limit: int | None = None,
               follow_links: bool = True) -> bytes:
    """The bytes of the regular file ``path``, refused past ``limit`` bytes before any is read.

    Raises
    ------
    FileTooLargeError
        The file is larger than ``limit`` bytes.
    UnsafeFileError, OSError
        As :func:`open_regular`, or a read error, naming ``path``.
    """
    path = Path(path)
    fd = open_regular(path, what, follow_links=follow_links)
    try:
        size = os.fstat(fd).st_size
        if limit is not None and size > limit:
            raise FileTooLargeError(f"{what} {path} is {size:,} bytes, more than the {limit:,} it can need; not read")
        with os.fdopen(fd, "rb", closefd=False) as f:
            data = f.read() if limit is None else f.read(limit + 1)
        if limit is not None and len(data) > limit:  # it grew while being read
            raise FileTooLargeError(f"{what} {path} is more than the {limit:,} bytes it can need; not read")
        return data
    except OSError as exc:
        if isinstance(exc, (FileTooLargeError, UnsafeFileError)):
            raise
        raise _os_error(exc, path, what, follow_links) from None
    finally:
        os.close(fd)


def read_head(path: str | os.PathLike, n: int, what: str = "file", *, follow_links: bool = True) -> tuple[bytes, int]:
    """The first ``n`` bytes of the regular file ``path`` and its size, reading nothing more."""
    path = Path(path)
    fd = open_regular(path, what, follow_links=follow_links)
    try:
        size = os.fstat(fd).st_size
        return os.read(fd, n), size
    except OSError as exc:
        raise _os_error(exc, path, what, follow_links) from None
    finally:
        os.close(fd)


def read_text(path: str | os.PathLike, what: str = "file", *, limit: int, encoding: str = "utf-8",
              follow_links: bool = True) -> str:
    """The text of the regular file ``path`` (at most ``limit`` bytes), one clear error if it does not decode.

    Raises
    ------
    UnsafeFileError
        Not valid ``encoding`` (the message names the file), or as :func:`read_bytes`.
    """
    data = read_bytes(path, what, limit=limit, follow_links=follow_links)
    try:
        return data.decode(encoding)
    except UnicodeDecodeError as exc:
        raise UnsafeFileError(f"{what} {Path(path)} is not {encoding} text (byte {exc.start}); not read") from None
