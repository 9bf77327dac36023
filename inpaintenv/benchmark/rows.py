"""The row files of a run folder (``rows/<method>__<protocol>.jsonl``, ``partial-rows.jsonl``).

One JSON object per line, appended as batches are scored so that a killed run keeps
them. They live in a folder the run owns, so they are read and appended without
following a link (:func:`inpaintenv.files.append_text`): a link planted at a row file is
refused, never written through, and a FIFO there is refused at once.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import reprlib
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any

from ..data.inputs import INPUT_KINDS
from ..data.inputs import input_kind as input_kind_of
from ..exceptions import JSONFileError, ResultRowError, RunStateError
from ..files import MAX_JSON_BYTES, append_text, loads_json, open_regular, read_text
from ..values.rows import RowPlan, SameFrames, UniqueRows, check_row

__all__ = ["append_rows", "end_partial_line", "read_rows", "read_run_rows", "rows_file_name"]


def rows_file_name(method: str, protocol: str, input_kind: str = "map") -> str:
    """``<method>__<protocol>.jsonl``, the row file of a method's task on maps; on another input its
    name ends in the input's tag (``__scan``, ``__scan-rings16-v1``)."""
    return f"{_slug(method)}__{_slug(protocol)}{input_kind_of(input_kind).file_tag}.jsonl"


def _slug(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name)


def read_rows(path: Path, plan: RowPlan | None = None, *, unique: UniqueRows | None = None,
              check: Callable[[dict[str, Any], str], None] | None = None) -> list[dict[str, Any]]:
    """The rows of the row file ``path`` (none if it is missing), each a possible row of this run.

    A line that is not JSON (the partial last line of a killed run) is skipped. Every
    other line must be a possible row (:func:`inpaintenv.values.rows.check_row`), planned
    by the run (``plan``: its method, task, seeds and frames) and the only one of its key:
    a row file is the run's own, so a row that is none of these was put there by someone
    else, and which score of a frame is true is not for a resume to guess. ``unique`` (shared
    by the files of one folder) refuses a key seen in another file too; ``check(row, where)``
    is a further check of each row (a ResultRowError it raises names the line as the others do).

    Raises
    ------
    RunStateError
        A line that is JSON but not a row of this run (the message names the file, the
        line and the column).
    UnsafeFileError, FileTooLargeError
        ``path`` is a link, FIFO or device, or larger than any row file can be.
    """
    if not os.path.lexists(path):
        return []
    rows = []
    if unique is None:
        unique = UniqueRows(default_input=plan.input_kind if plan is not None else "map")
    text = read_text(path, "row file", limit=MAX_JSON_BYTES, follow_links=False)
    for number, line in enumerate(text.splitlines(), 1):
        if not line.strip():
            continue
        try:
            raw = loads_json(line, f"line {number} of {path}")
        except JSONFileError:
            continue
        where = f"line {number} of {path}"
        try:
            row = check_row(raw)
            if plan is not None:
                plan.check(row)
            if check is not None:
                check(row, where)
            unique.add(row, where)
        except ResultRowError as exc:
            raise RunStateError(f"{where} is not a row of this run: {exc}; pass --no-resume (resume=False) to score "
                                "again from scratch, or delete that line") from None
        rows.append(row)
    return rows


def read_run_rows(rows_dir: Path, run: Mapping[str, Any]) -> list[dict[str, Any]]:
    """Every row of a run folder's row files, for a reader without the run's data (a report).

    Each row is possible (:func:`read_rows`), lies in the file of its method and task, is of
    a task, seed and frame ``run`` (the folder's ``run.json``, or {} when there is none)
    records, is the only one of its key in the folder, and names its frame as every other
    row does; where the rows of an input kind cover each of its frames, their ids are the
    frames ``run.json`` fingerprinted.

    Raises
    ------
    RunStateError
        Naming the file, the line and what is wrong (as a resume does).
    """
    recorded = _recorded_tasks(run)
    seeds = run.get("seeds")
    seeds = set(seeds) if isinstance(seeds, list) and all(type(s) is int for s in seeds) else None
    unique, frames = UniqueRows(), SameFrames()

    def check(row: dict[str, Any], where: str, name: str, kind: str) -> None:
        row.setdefault("input_kind", kind)
        if row["input_kind"] not in INPUT_KINDS:
            raise ResultRowError(f"input_kind {reprlib.repr(row['input_kind'])} is none of {', '.join(INPUT_KINDS)}")
        own = rows_file_name(row["method"], row["protocol"], row["input_kind"])
        if own != name:
            raise ResultRowError(f"its method {reprlib.repr(row['method'])} and task ({reprlib.repr(row['protocol'])}, "
                                 f"{reprlib.repr(row['input_kind'])}) write to {reprlib.repr(own)}, not {name}")
        task = recorded.get(row["input_kind"])
        if recorded and task is None:
            raise ResultRowError(f"input_kind {reprlib.repr(row['input_kind'])} is not one run.json records")
        for column, ok in (("protocol", task is None or row["protocol"] in task[0]),
                           ("index", task is None or row["index"] < task[1]),
                           ("drive", task is None or task[3] is None or row["drive"] in task[3]),
                           ("seed", seeds is None or row["seed"] in seeds)):
            if not ok:
                raise ResultRowError(f"{column} {reprlib.repr(row[column])} is not one run.json records")
        frames.add(row, where)

    rows = []
    for path in sorted(rows_dir.glob("*.jsonl")):
        kind = "scan" if path.stem.endswith("__scan") else "map"
        rows += read_rows(path, unique=unique, check=lambda r, w, n=path.name, k=kind: check(r, w, n, k))
    for kind, (_, n_frames, sha1, _) in recorded.items():
        ids = frames.ids(kind, n_frames)
        if ids is not None and sha1 is not None and hashlib.sha1("\n".join(ids).encode()).hexdigest() != sha1:
            raise RunStateError(f"the rows in {rows_dir} name {kind} frames other than the ones run.json records "
                                "(their ids); pass --no-resume to score again from scratch")
    return rows


def _recorded_tasks(run: Mapping[str, Any]) -> dict[str, tuple[set[str], int, str | None, set[str] | None]]:
    """Input kind -> (protocols, frames in play, the frames' sha1, the drives when it names them: its
    ``data`` digests) as ``run.json`` records them ({} if it does not)."""
    # The fingerprint of the map's (else the first kind's) at the top, each other kind's under its name.
    keys = {run.get("input_kind", "map") if isinstance(run.get("input_kind"), str) else "map": run}
    keys.update({kind: run[kind] for kind in INPUT_KINDS if isinstance(run.get(kind), Mapping)})
    out = {}
    for kind, key in keys.items():
        protocols, n_frames, sha1 = key.get("protocols"), key.get("n_frames"), key.get("frames_sha1")
        data = key.get("data")
        if isinstance(protocols, list) and all(isinstance(p, str) for p in protocols) and type(n_frames) is int:
            out[kind] = (set(protocols), n_frames, sha1 if isinstance(sha1, str) else None,
                         set(data) if isinstance(data, Mapping) and data else None)
    return out


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
