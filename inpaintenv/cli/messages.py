"""Lines for the user on stderr that print whatever the stream's encoding.

File names that are not UTF-8 reach messages as lone surrogates (Python's
``surrogateescape``); a stream that encodes strictly (ASCII, or UTF-8 as a test's or an
embedding program's capture does) would raise ``UnicodeEncodeError`` on them and turn a
one-line error into a traceback. Such characters are written as backslash escapes instead.
"""

from __future__ import annotations

import sys
from typing import TextIO

__all__ = ["print_line"]


def print_line(text: str, file: TextIO | None = None) -> None:
    """Print ``text`` to ``file`` (stderr by default), characters its encoding lacks backslash-escaped.

    Parameters
    ----------
    text : str
        The line (without its newline).
    file : text stream, optional
        Where to print; ``sys.stderr`` when not given.
    """
    stream = sys.stderr if file is None else file
    encoding = getattr(stream, "encoding", None) or "utf-8"
    try:
        safe = text.encode(encoding, "backslashreplace").decode(encoding)
    except LookupError:  # a stream naming an encoding Python does not know
        safe = text.encode("ascii", "backslashreplace").decode("ascii")
    print(safe, file=stream, flush=True)
