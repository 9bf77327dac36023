"""Report files written whole or not at all.

Every report file (JSON, CSV, Markdown, figures) is written to a temporary file in its
own folder, flushed to disk and moved over the old one with ``os.replace``: a full disk
or a kill mid-write leaves the previous file intact instead of a truncated one, and the
error names the file that could not be written.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

__all__ = ["TEMP_SUFFIX", "write_atomic", "write_text_atomic"]

#: Suffix of the temporary files (``.<name>.<random>.tmp``) while a file is written.
TEMP_SUFFIX = ".tmp"


def write_atomic(path: str | os.PathLike, write: Callable[[Path], Any]) -> Path:
    """Call ``write(tmp)`` on a temporary file beside ``path``, fsync it, move it to ``path``.

    Parameters
    ----------
    path : path-like
        The file to write (its folder is created if missing).
    write : callable
        Writes the whole content to the path it is given (a file of the same folder,
        ending with ``path``'s own suffix so writers that choose a format by the name,
        as matplotlib does, choose the same).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    OSError
        The cause (e.g. no space left on device) with ``path`` named; ``path`` is unchanged.
    """
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=f"{TEMP_SUFFIX}{path.suffix}", dir=path.parent)
        os.close(fd)
    except OSError as exc:
        raise _naming(exc, path) from None
    tmp = Path(name)
    try:
        write(tmp)
        with open(tmp, "rb+") as f:
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException as exc:
        tmp.unlink(missing_ok=True)
        if isinstance(exc, OSError):
            raise _naming(exc, path) from None
        raise
    return path


def write_text_atomic(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` whole or not at all (see :func:`write_atomic`)."""
    return write_atomic(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))


def _naming(exc: OSError, path: Path) -> OSError:
    """``exc`` as an OSError of the same errno whose message names ``path``."""
    reason = exc.strerror or str(exc) or type(exc).__name__
    message = f"cannot write {path}: {reason}"
    return OSError(exc.errno, message) if exc.errno is not None else OSError(message)
