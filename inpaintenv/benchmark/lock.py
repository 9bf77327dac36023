"""One run per run folder: an OS-level lock file ``<out>/run.lock``.

Two benchmark runs writing the same folder would score everything twice and append
every row twice. The first run takes an exclusive ``fcntl.flock`` on ``run.lock`` and
writes its pid, host and start time into it; a second run fails at once with a line
naming the holder. The kernel drops a flock when its process dies (even on SIGKILL),
so a lock left by a killed run is free: the next run takes it over and says so. Where
``fcntl`` does not exist (Windows) or the file system has no flock, the file is created
exclusively instead and a holder whose pid is not alive on this host counts as stale.

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

from ..exceptions import RunLockedError

try:  # POSIX
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None  # type: ignore[assignment]

__all__ = ["LOCK_FILE", "RunLockedError", "run_lock"]

#: Name of the lock file inside a run folder.
LOCK_FILE = "run.lock"

# Locks this process holds: resolved path -> [open file, depth of nesting, flocked?].
_HELD: dict[Path, list[Any]] = {}


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # alive, owned by someone else
        return True
    except OSError:
        return False
    return True


def _holder_text(info: dict[str, Any]) -> str:
    return f"pid {info.get('pid', '?')} on {info.get('host', '?')}, started {info.get('started', '?')}"


def _read_holder(f: Any) -> dict[str, Any]:
    f.seek(0)
    try:
        info = json.loads(f.read() or "{}")
    except ValueError:
        return {}
    return info if isinstance(info, dict) else {}


def _me() -> dict[str, Any]:
    return {
        "pid": os.getpid(),
        "host": socket.gethostname(),
        "started": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
    }


def _acquire_flock(path: Path, say: Callable[[str], None]) -> Any | None:
    """The open, flocked lock file; None if this file system has no flock."""
    f = open(path, "a+")  # noqa: SIM115 - held until release
    try:
        fcntl.flock(f.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        holder = _read_holder(f)
        f.close()
        raise RunLockedError(
            f"{path.parent} is in use by another run ({_holder_text(holder)}); wait for it to finish "
            "or choose another --out"
        ) from None
    except OSError:  # a file system without flock (some network mounts): lock file + pid check
        f.close()
        return None
    previous = _read_holder(f)
    if previous:
        # Written by a run that never released it: it was killed (the kernel dropped its flock).
        say(f"taking over the stale lock of {path.parent} ({_holder_text(previous)}; that process is gone)")
    f.seek(0)
    f.truncate()
    f.write(json.dumps(_me()))
    f.flush()
    return f


def _acquire_exclusive(path: Path, say: Callable[[str], None]) -> Any:  # pragma: no cover - no flock
    """The lock file created exclusively; a holder not alive on this host is stale."""
    for _ in range(2):
        try:
            fd = os.open(path, os.O_CREAT | os.O_EXCL | os.O_RDWR)
        except FileExistsError:
            with open(path) as f:
                holder = _read_holder(f)
            pid = holder.get("pid")
            if holder.get("host") == socket.gethostname() and isinstance(pid, int) and not _pid_alive(pid):
                say(f"taking over the stale lock of {path.parent} ({_holder_text(holder)}; that process is gone)")
                path.unlink(missing_ok=True)
                continue
            raise RunLockedError(
                f"{path.parent} is in use by another run ({_holder_text(holder)}); wait for it to finish, "
                f"choose another --out, or delete {path} if that run is gone"
            ) from None
        f = os.fdopen(fd, "w+")
        f.write(json.dumps(_me()))
        f.flush()
        return f
    raise RunLockedError(f"could not take the lock {path}")


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
    """
    out = Path(out_dir)
    if out.exists() and not out.is_dir():
        raise NotADirectoryError(f"--out {out} is a file; the run folder must be a folder")
    out.mkdir(parents=True, exist_ok=True)
    path = (out / LOCK_FILE).resolve()
    held = _HELD.get(path)
    if held is not None:
        held[1] += 1
    else:
        say = log or (lambda msg: None)
        f = _acquire_flock(path, say) if fcntl is not None else None
        flocked = f is not None
        if f is None:
            f = _acquire_exclusive(path, say)
        _HELD[path] = held = [f, 1, flocked]
    try:
        yield path
    finally:
        held[1] -= 1
        if held[1] == 0:
            del _HELD[path]
            f = held[0]
            if held[2]:
                # Emptied, not deleted: deleting a flocked file lets two runs lock two inodes.
                f.seek(0)
                f.truncate()
                f.flush()
                fcntl.flock(f.fileno(), fcntl.LOCK_UN)
                f.close()
            else:  # pragma: no cover - no flock here
                f.close()
                path.unlink(missing_ok=True)
