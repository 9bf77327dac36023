"""Writing files: whole or not at all, never through a planted link.

Every write of the package goes through :func:`write_atomic`: the content goes to a
temporary file created exclusively (``O_EXCL | O_NOFOLLOW``) under an unpredictable,
short name in the target's folder, is flushed to disk and renamed over the target.
A rename replaces a symbolic link at the target rather than writing through it, a kill
mid-write leaves the previous file intact, and the temporary name does not grow with
the target's, so a 250-byte file name is written like any other. Temporary files carry
the writer's process id, so :func:`remove_stale_temporaries` can clear those a killed
run left behind. Appends (row files) and lock files open without following a link and
refuse anything but a regular file.
"""

from __future__ import annotations

import errno
import os
import secrets
import shutil
import stat
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..exceptions import UnsafeFileError
from .processes import writer_gone
from .reading import describe_kind

__all__ = [
    "TEMP_PREFIX", "append_text", "open_lock", "remove_stale_temporaries", "write_atomic", "write_bytes_atomic",
    "write_folder_atomic", "write_text_atomic",
]

#: Prefix of every temporary file while a file is written: ``.inpaintenv-tmp-<pid>-<random><suffix>``.
TEMP_PREFIX = ".inpaintenv-tmp-"
_CLOEXEC = getattr(os, "O_CLOEXEC", 0)


def _naming(exc: OSError, path: Path, what: str = "") -> OSError:
    """``exc`` as an OSError of the same errno whose message names ``path``."""
    if isinstance(exc, UnsafeFileError):
        return exc
    reason = exc.strerror or str(exc) or type(exc).__name__
    message = f"cannot write {what + ' ' if what else ''}{path}: {reason}"
    if isinstance(exc, PermissionError) or exc.errno == errno.EROFS:
        return PermissionError(exc.errno, message)
    return OSError(exc.errno, message) if exc.errno is not None else OSError(message)


def _temporary(folder: Path, suffix: str) -> Path:
    """A new, empty file of ``folder`` under an unpredictable name, created exclusively."""
    name = f"{TEMP_PREFIX}{os.getpid()}-{secrets.token_hex(8)}{suffix[:16]}"
    fd = os.open(folder / name, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | _CLOEXEC, 0o666)
    os.close(fd)
    return folder / name


def _owned_folder(folder: Path, within: Path, what: str) -> None:
    """Create ``folder`` (inside ``within``) one level at a time; refuse a link or a file on the way.

    Each component between ``within`` and ``folder`` is checked with ``os.lstat``: a
    symbolic link there (to a folder elsewhere) would take ``what`` out of ``within``.
    """
    folder, within = Path(os.path.abspath(folder)), Path(os.path.abspath(within))
    try:
        parts = folder.relative_to(within).parts
    except ValueError:
        raise ValueError(f"{what}: {folder} is not inside {within}") from None
    within.mkdir(parents=True, exist_ok=True)
    current = within
    for part in parts:
        current = current / part
        try:
            mode = os.lstat(current).st_mode
        except FileNotFoundError:
            try:
                os.mkdir(current)
            except FileExistsError:  # made meanwhile: checked below like any other
                pass
            mode = os.lstat(current).st_mode
        if stat.S_ISLNK(mode):
            raise UnsafeFileError(f"cannot write {what}: {current} is a symbolic link inside {within}, the folder "
                                  "this command owns; nothing is written through a link")
        if not stat.S_ISDIR(mode):
            raise NotADirectoryError(errno.ENOTDIR, f"{current} is {describe_kind(mode)}, not a folder")


def write_atomic(path: str | os.PathLike, write: Callable[[Path], Any], what: str = "", *,
                 within: str | os.PathLike | None = None) -> Path:
    """Call ``write(tmp)`` on a fresh temporary file beside ``path``, fsync it, rename it to ``path``.

    Parameters
    ----------
    path : path-like
        The file to write (its folder is created if missing). A symbolic link there is
        replaced, never written through.
    write : callable
        Writes the whole content to the path it is given (a file of the same folder
        ending with ``path``'s suffix, so writers that choose a format by the name, as
        matplotlib does, choose the same).
    what : str
        What the file is, for messages.
    within : path-like, optional
        The folder the command owns (e.g. ``--out``), which ``path`` lies in: no folder
        between it and ``path`` may be a symbolic link (one planted there would take the
        file elsewhere); missing folders are created without following one.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    UnsafeFileError
        A folder between ``within`` and ``path`` is a symbolic link; nothing is written.
    OSError
        The cause (e.g. no space left on device) with ``path`` named; ``path`` is unchanged.
    ValueError
        ``path`` does not lie inside ``within``.
    """
    path = Path(path)
    try:
        if within is not None:
            _owned_folder(path.parent, Path(within), f"{what + ' ' if what else ''}{path}")
        path.parent.mkdir(parents=True, exist_ok=True)
        if path.is_dir() and not path.is_symlink():
            raise IsADirectoryError(errno.EISDIR, "it is a folder")
        tmp = _temporary(path.parent, path.suffix)
    except OSError as exc:
        raise _naming(exc, path, what) from None
    try:
        write(tmp)
        fd = os.open(tmp, os.O_RDONLY | os.O_NOFOLLOW | _CLOEXEC)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(tmp, path)
    except BaseException as exc:
        tmp.unlink(missing_ok=True)
        if isinstance(exc, OSError):
            raise _naming(exc, path, what) from None
        raise
    return path


def write_folder_atomic(path: str | os.PathLike, write: Callable[[Path], Any], what: str = "", *,
                        within: str | os.PathLike | None = None) -> Path:
    """Call ``write(tmp)`` on a fresh temporary folder beside ``path`` and rename it to ``path``.

    A folder is whole or absent: a failure (a full disk) or a kill while ``write`` runs
    leaves no folder named ``path`` (a killed writer's temporary folder is cleared by
    :func:`remove_stale_temporaries` with ``folders=True``).

    Parameters
    ----------
    path : path-like
        The folder to write; it must not exist (write under a fresh name).
    write : callable
        Writes the folder's files into the folder it is given (each through :func:`write_atomic`).
    what : str
        What the folder is, for messages.
    within : path-like, optional
        The folder the command owns, which ``path`` lies in: no folder between it and
        ``path`` may be a symbolic link (as :func:`write_atomic`'s).

    Raises
    ------
    UnsafeFileError
        A folder between ``within`` and ``path`` is a symbolic link; nothing is written.
    OSError
        The cause (e.g. no space left on device) with ``path`` named; nothing is left behind.
    """
    path = Path(path)
    try:
        if within is not None:
            _owned_folder(path.parent, Path(within), f"{what + ' ' if what else ''}{path}")
        path.parent.mkdir(parents=True, exist_ok=True)
        if os.path.lexists(path):
            raise FileExistsError(errno.EEXIST, "it exists already")
        tmp = path.parent / f"{TEMP_PREFIX}{os.getpid()}-{secrets.token_hex(8)}"
        os.mkdir(tmp)
    except OSError as exc:
        raise _naming(exc, path, what) from None
    try:
        write(tmp)
        os.rename(tmp, path)
    except BaseException as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        if isinstance(exc, OSError) and not isinstance(exc, UnsafeFileError):
            # The cause alone: a message naming the temporary file would name a file that is gone.
            reason = os.strerror(exc.errno) if exc.errno else str(exc)
            raise OSError(exc.errno, f"cannot write {what + ' ' if what else ''}{path}: {reason}; nothing of it "
                                     "was kept") from None
        raise
    return path


def write_bytes_atomic(path: str | os.PathLike, data: bytes, what: str = "", *,
                       within: str | os.PathLike | None = None) -> Path:
    """Write ``data`` to ``path`` whole or not at all (see :func:`write_atomic`)."""
    return write_atomic(path, lambda tmp: tmp.write_bytes(data), what, within=within)


def write_text_atomic(path: str | os.PathLike, text: str, what: str = "", *,
                      within: str | os.PathLike | None = None) -> Path:
    """Write ``text`` (UTF-8) to ``path`` whole or not at all (see :func:`write_atomic`)."""
    return write_atomic(path, lambda tmp: tmp.write_text(text, encoding="utf-8"), what, within=within)


def _open_owned(path: Path, flags: int, what: str) -> int:
    """Open a file of a folder the command owns: no link followed, regular files only."""
    try:
        fd = os.open(path, flags | os.O_NOFOLLOW | os.O_NONBLOCK | _CLOEXEC, 0o666)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise UnsafeFileError(f"{what} {path} is a symbolic link; a command writes its own files only, never "
                                  "through a link") from None
        raise _naming(exc, path, what) from None
    mode = os.fstat(fd).st_mode
    if not stat.S_ISREG(mode):
        os.close(fd)
        raise UnsafeFileError(f"{what} {path} is {describe_kind(mode)}, not a regular file; not written")
    return fd


def append_text(path: str | os.PathLike, text: str, what: str = "file") -> None:
    """Append ``text`` (UTF-8) to the regular file ``path`` (created if missing), never through a link.

    Raises
    ------
    UnsafeFileError
        ``path`` is a symbolic link, a FIFO, a device or a socket.
    OSError
        The cause, naming ``path``.
    """
    path = Path(path)
    fd = _open_owned(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, what)
    try:
        data = text.encode("utf-8")
        while data:
            data = data[os.write(fd, data):]
    except OSError as exc:
        raise _naming(exc, path, what) from None
    finally:
        os.close(fd)


def open_lock(path: str | os.PathLike, what: str = "lock file") -> int:
    """Open (create) the lock file ``path`` for reading and writing without truncating or following a link.

    Returns
    -------
    int
        The descriptor (the caller locks, writes and closes it).

    Raises
    ------
    UnsafeFileError
        ``path`` is a symbolic link or not a regular file.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    return _open_owned(path, os.O_RDWR | os.O_CREAT, what)


def _through_link(folder: Path, within: Path) -> bool:
    """Whether a component of ``folder`` below ``within`` is a symbolic link (or ``folder`` is not inside it)."""
    folder, within = Path(os.path.abspath(folder)), Path(os.path.abspath(within))
    try:
        parts = folder.relative_to(within).parts
    except ValueError:
        return True
    current = within
    for part in parts:
        current = current / part
        try:
            if stat.S_ISLNK(os.lstat(current).st_mode):
                return True
        except OSError:
            return False  # missing: nothing to remove there
    return False


def remove_stale_temporaries(folder: str | os.PathLike, within: str | os.PathLike | None = None, *,
                             folders: bool = False) -> list[Path]:
    """Remove the temporary files of :func:`write_atomic` in ``folder`` whose writer is no longer running.

    Only regular files named ``.inpaintenv-tmp-<pid>-...`` of a process that has ended
    are removed (a kill -9 mid-write leaves one); nothing else is touched, a name whose
    pid does not parse (:func:`~inpaintenv.files.processes.parse_pid`) included.

    Parameters
    ----------
    folder : path-like
        The folder to clear.
    within : path-like, optional
        The folder the command owns: nothing is removed when ``folder`` is reached from
        it through a symbolic link (or lies outside it).
    folders : bool
        Also remove such folders (of :func:`write_folder_atomic`), with what they hold.

    Returns
    -------
    list of Path
        The files removed.
    """
    removed: list[Path] = []
    if within is not None and _through_link(Path(folder), Path(within)):
        return removed
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for entry in entries:
        if not entry.name.startswith(TEMP_PREFIX):
            continue
        if not writer_gone(entry.name[len(TEMP_PREFIX):].split("-", 1)[0]):
            continue
        try:
            if entry.is_file(follow_symlinks=False):
                os.unlink(entry.path)
                removed.append(Path(entry.path))
            elif folders and entry.is_dir(follow_symlinks=False):
                shutil.rmtree(entry.path)
                removed.append(Path(entry.path))
        except OSError:
            pass
    return removed
