"""The row files of a run folder (``rows/<method>__<protocol>.jsonl``, ``partial-rows.jsonl``).

One JSON object per line, appended as batches are scored so that a killed run keeps
them. They live in a folder the run owns, so they are read and appended without
following a link (:func:`inpaintenv.files.append_text`): a link planted at a row file is
refused, never written through, and a FIFO there is refused at once.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from ..exceptions import JSONFileError, RunStateError
from ..files import MAX_JSON_BYTES, append_text, loads_json, open_regular, read_text
from ..report.results import parse_row

__all__ = ["append_rows", "end_partial_line", "read_rows"]


def read_rows(path: Path) -> list[dict[str, Any]]:
    """The rows of the row file ``path`` (none if it is missing).

    A line that is not JSON (the partial last line of a killed run) is skipped.

    Raises
    ------
    RunStateError
        A line that is JSON but not a row (the message names the file and line).
    UnsafeFileError, FileTooLargeError
        ``path`` is a link, FIFO or device, or larger than any row file can be.
    """
    if not os.path.lexists(path):
        return []
    rows = []
    text = read_text(path, "row file", limit=MAX_JSON_BYTES, follow_links=False)
    for number, line in enumerate(text.splitlines(), 1):
        if not line.strip():
            continue
        try:
            raw = loads_json(line, f"line {number} of {path}")
        except JSONFileError:
            continue
        try:
            rows.append(_row(raw))
        except (KeyError, TypeError, ValueError, OverflowError):
            raise RunStateError(f"line {number} of {path} is not a row of a run; pass --no-resume (resume=False) "
                                "to start over, or delete the file") from None
    return rows


def _row(raw: Any) -> dict[str, Any]:
    """``raw`` as a row: a JSON object with a method name, an integer seed and frame index."""
    if not isinstance(raw, dict):
        raise TypeError
    row = parse_row(raw)
    if not isinstance(row["method"], str) or not isinstance(row["seed"], int) or not isinstance(row["index"], int):
        raise TypeError
    return row


def end_partial_line(path: Path) -> None:
    """End the row file ``path`` with a newline if a kill mid-write left a partial last line."""
    if not os.path.lexists(path):
        return
    fd = open_regular(path, "row file", follow_links=False)
    try:
        size = os.fstat(fd).st_size
        if size:
            os.lseek(fd, size - 1, os.SEEK_SET)
            ended = os.read(fd, 1) == b"\n"
        else:
            ended = True
    finally:
        os.close(fd)
    if not ended:
        append_text(path, "\n", "row file")


def append_rows(path: Path, rows: Iterable[dict[str, Any]]) -> None:
    """Append ``rows`` to the row file ``path`` (created if missing), one JSON object a line."""
    append_text(path, "".join(json.dumps(row) + "\n" for row in rows), "row file")
