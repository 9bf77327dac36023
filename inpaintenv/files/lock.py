"""One run per run folder: an OS-level lock file ``<out>/run.lock``.

Two benchmark runs writing the same folder would score everything twice and append
every row twice. The first run takes an exclusive ``fcntl.flock`` on ``run.lock`` and
writes its pid, host and start time into it; a second run fails at once with a line
naming the holder. The kernel drops a flock when its process dies (even on SIGKILL),
so a lock left by a killed run is free: the next run takes it over and says so. Where
``fcntl`` does not exist (Windows) or the file system has no flock, the file is created
exclusively instead and a holder whose pid is not alive on this host counts as stale.

The lock file is opened without truncating it and without following a link
(:func:`inpaintenv.files.open_lock`): a symbolic link, FIFO or device planted at
``run.lock`` is refused in one line and nothing it points to is touched.

The lock is re-entrant within a process (the CLI and :func:`run_benchmark` both take
it) and released on exit from the ``with`` block, including on errors and Ctrl-C.
"""

from __future__ import annotations

import contextlib
import datetime
import json
import os
import socket
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from ..exceptions import InpaintenvError, RunLockedError
from .jsonio import loads_json
from .processes import writer_gone
from .writing import open_lock

try:  # POSIX
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None  # type: ignore[assignment]

__all__ = ["LOCK_FILE", "RunLockedError", "holds_lock", "run_lock"]

#: Name of the lock file inside a run folder.
LOCK_FILE = "run.lock"

#: The most bytes of a lock file read (its holder's pid, host and start time).
_HOLDER_BYTES = 4096

# Locks this process holds: path (folder resolved) -> [descriptor, depth of nesting, flocked?].
_HELD: dict[Path, list[Any]] = {}


def _holder_text(info: dict[str, Any]) -> str:
    return f"pid {info.get('pid', '?')} on {info.get('host', '?')}, started {info.get('started', '?')}"


def _read_holder(fd: int) -> dict[str, Any]:
    """What the lock file open at ``fd`` says about its holder (empty if nothing or nothing readable)."""
    try:
        os.lseek(fd, 0, os.SEEK_SET)
        info = loads_json(os.read(fd, _HOLDER_BYTES) or b"{}", "lock file")
    except (OSError, InpaintenvError):
        return {}
    return info if isinstance(info, dict) else {}


def _write_holder(fd: int) -> None:
    """Replace the lock file's content (open at ``fd``) with this process's pid, host and start time."""
    me = {
        "pid": os.getpid(),
        "host": socket.gethostname(),
        "started": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
    }
    os.ftruncate(fd, 0)
    os.lseek(fd, 0, os.SEEK_SET)
    os.write(fd, json.dumps(me).encode())


def _acquire_flock(path: Path, say: Callable[[str], None]) -> int | None:
    """The open, flocked lock file's descriptor; None if this file system has no flock."""
    fd = open_lock(path)  # never truncates, never follows a link planted at run.lock
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        holder = _read_holder(fd)
        os.close(fd)
        raise RunLockedError(
            f"{path.parent} is in use by another run ({_holder_text(holder)}); wait for it to finish "
            "or choose another --out"
        ) from None
    except OSError:  # a file system without flock (some network mounts): lock file + pid check
        os.close(fd)
        return None
    previous = _read_holder(fd)
    if previous:
        # Written by a run that never released it: it was killed (the kernel dropped its flock).
        say(f"taking over the stale lock of {path.parent} ({_holder_text(previous)}; that process is gone)")
    _write_holder(fd)
    return fd


def _acquire_exclusive(path: Path, say: Callable[[str], None]) -> int:  # pragma: no cover - no flock
    """The lock file created exclusively; a holder not alive on this host is stale."""
    for _ in range(2):
        try:
            fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_RDWR | getattr(os, "O_NOFOLLOW", 0))
        except FileExistsError:
            fd = open_lock(path)
            holder = _read_holder(fd)
            os.close(fd)
            if holder.get("host") == socket.gethostname() and writer_gone(holder.get("pid")):
                say(f"taking over the stale lock of {path.parent} ({_holder_text(holder)}; that process is gone)")
                path.unlink(missing_ok=True)
                continue
            raise RunLockedError(
                f"{path.parent} is in use by another run ({_holder_text(holder)}); wait for it to finish, "
                f"choose another --out, or delete {path} if that run is gone"
            ) from None
        _write_holder(fd)
        return fd
    raise RunLockedError(f"could not take the lock {path}")


def holds_lock(out_dir: str | os.PathLike) -> bool:
    """Whether this process holds the run lock of folder ``out_dir`` (a ``run_lock`` block is open).

    A command checks its folder (:func:`inpaintenv.files.ownership.check_folder`) before it takes
    the lock, so what runs inside the block need not check it again.
    """
    out = Path(out_dir)
    return out.is_dir() and out.resolve() / LOCK_FILE in _HELD


@contextlib.contextmanager
def run_lock(out_dir: str | os.PathLike, log: Callable[[str], None] | None = None) -> Iterator[Path]:
    """Hold the lock of run folder ``out_dir`` (created if missing) for the ``with`` block.

    Parameters
    ----------
    out_dir : path-like
        The run folder.
    log : callable, optional
        Receives one line when a stale lock of a killed run is taken over.

    Raises
    ------
    RunLockedError
        If another live process holds the lock (the message names it).
    UnsafeFileError
        If ``run.lock`` is a symbolic link or not a regular file (nothing is written through it).
    """
    out = Path(out_dir)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except FileExistsError:  # a file there: the folder checks name it first, this is the last guard
        raise NotADirectoryError(f"--out {out} is a file; the run folder must be a folder") from None
    # The folder is resolved, never the lock file: a link planted at run.lock is refused, not followed.
    path = out.resolve() / LOCK_FILE
    held = _HELD.get(path)
    if held is not None:
        held[1] += 1
    else:
        say = log or (lambda msg: None)
        fd = _acquire_flock(path, say) if fcntl is not None else None
        flocked = fd is not None
        if fd is None:
            fd = _acquire_exclusive(path, say)
        _HELD[path] = held = [fd, 1, flocked]
    try:
        yield path
    finally:
        held[1] -= 1
        if held[1] == 0:
            del _HELD[path]
            fd = held[0]
            if held[2]:
                # Emptied, not deleted: deleting a flocked file lets two runs lock two inodes.
                os.ftruncate(fd, 0)
                fcntl.flock(fd, fcntl.LOCK_UN)
                os.close(fd)
            else:  # pragma: no cover - no flock here
                os.close(fd)
                path.unlink(missing_ok=True)
