"""JSON in and out: bounded in size and nesting, written whole or not at all."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

from ..exceptions import JSONFileError
from .limits import MAX_JSON_BYTES, MAX_JSON_DEPTH
from .reading import read_bytes
from .writing import write_text_atomic

__all__ = ["loads_json", "read_json", "write_json"]


def _depth(value: Any) -> int:
    """The nesting depth of a parsed document (iterative: no recursion on hostile input)."""
    deepest, stack = 0, [(value, 1)]
    while stack:
        item, level = stack.pop()
        if isinstance(item, dict):
            deepest = max(deepest, level)
            stack.extend((v, level + 1) for v in item.values())
        elif isinstance(item, list):
            deepest = max(deepest, level)
            stack.extend((v, level + 1) for v in item)
    return deepest


def _no_constant(name: str) -> Any:
    raise ValueError(f"{name} is not a JSON number")


def loads_json(text: str | bytes, what: str = "JSON", *, max_depth: int = MAX_JSON_DEPTH,
               allow_nan: bool = True) -> Any:
    """Parse ``text``; refuse broken or too deeply nested documents in one line.

    Parameters
    ----------
    text : str or bytes
        The document (bytes are decoded as UTF-8).
    what : str
        What the document is, for messages (``"checkpoint config"``, ``"state.json of run R"``).
    max_depth : int
        Deepest nesting of objects and arrays accepted.
    allow_nan : bool
        Accept the non-standard ``NaN``/``Infinity`` constants (Python writes them); False where a number must be finite.

    Raises
    ------
    JSONFileError
        Naming ``what`` and the problem.
    """
    if isinstance(text, (bytes, bytearray)):
        try:
            text = bytes(text).decode("utf-8")
        except UnicodeDecodeError as exc:
            raise JSONFileError(f"{what} is not UTF-8 text (byte {exc.start})") from None
    try:
        doc = json.loads(text) if allow_nan else json.loads(text, parse_constant=_no_constant)
    except RecursionError:
        raise JSONFileError(f"{what} is nested deeper than the {max_depth} levels a file of this package has") from None
    except ValueError as exc:
        raise JSONFileError(f"{what} is not valid JSON: {exc}") from None
    if _depth(doc) > max_depth:
        raise JSONFileError(f"{what} is nested deeper than the {max_depth} levels a file of this package has")
    return doc


def read_json(path: str | os.PathLike, what: str = "JSON file", *, limit: int = MAX_JSON_BYTES,
              max_depth: int = MAX_JSON_DEPTH, follow_links: bool = True, allow_nan: bool = True) -> Any:
    """The parsed JSON file ``path``: a regular file of at most ``limit`` bytes, bounded nesting.

    Raises
    ------
    JSONFileError
        Broken, too deep, or NaN/Infinity with ``allow_nan=False``; the message names the file.
    FileTooLargeError, UnsafeFileError, OSError
        As :func:`inpaintenv.files.read_bytes`.
    """
    data = read_bytes(path, what, limit=limit, follow_links=follow_links)
    return loads_json(data, f"{what} {Path(path)}", max_depth=max_depth, allow_nan=allow_nan)


def write_json(path: str | os.PathLike, doc: Any, *, indent: int | None = 1) -> Path:
    """Write ``doc`` as JSON to ``path`` whole or not at all (see :func:`write_atomic`)."""
    return write_text_atomic(path, json.dumps(doc, indent=indent) + "\n")
