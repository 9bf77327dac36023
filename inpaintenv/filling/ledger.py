"""What made each output of ``--out``: so a rerun skips only its own outputs and replaces nothing else.

``fill`` records every input it writes in :data:`LEDGER` (``inpaintenv-fill.jsonl`` in
``--out``, JSON lines): the outputs (relative paths), the input (path, size, modification
time) and the recipe (the method's identity and every option that changes the pixels).
Each input gets two lines: an *intent* (``"intent": true``) appended before the first of
its outputs is written, and the record appended after the last. Before a run writes an
input's outputs, each output already there must be recorded, by either line, as made from
the same input by the same recipe; otherwise the input is refused in one line naming the
file and what differs (``--overwrite`` replaces it). An input whose outputs all exist and
whose latest line is the record is skipped; one whose latest line is an intent was cut
short (a kill between its outputs, several per input with ``--format both`` or
``--confidence``) and is redone, its files there replaced.

An append costs one line whatever the folder holds; a line cut short by a kill is ignored
(its outputs then count as not recorded: the intent is appended whole before any output).
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

from ..exceptions import InpaintenvError
from ..files import MAX_JSON_BYTES, append_text, loads_json, read_text, write_text_atomic
from .plan import FillJob

__all__ = ["LEDGER", "Ledger", "file_identity"]

#: The ledger's file name in ``--out``.
LEDGER = "inpaintenv-fill.jsonl"


def file_identity(path: str | os.PathLike) -> dict[str, Any]:
    """``{"path", "size", "mtime_ns"}`` of a file (or a folder's files, summed): what tells two versions apart."""
    p = Path(path)
    try:
        st = os.stat(p)
    except OSError:
        return {"path": str(p.absolute())}
    size, mtime = st.st_size, st.st_mtime_ns
    if p.is_dir():  # a checkpoint folder: its files' sizes and times, without reading them
        for root, _, files in os.walk(p):
            for name in files:
                try:
                    s = os.stat(Path(root) / name, follow_symlinks=False)
                except OSError:
                    continue
                size, mtime = size + s.st_size, max(mtime, s.st_mtime_ns)
    return {"path": str(p.resolve()), "size": size, "mtime_ns": mtime}


def _differences(old: dict[str, Any], new: dict[str, Any]) -> list[str]:
    """What differs between two records, in words."""
    out = []
    if old.get("input", {}).get("path") != new["input"]["path"]:
        out.append(f"from another input ({old.get('input', {}).get('path')})")
    elif old.get("input") != new["input"]:
        out.append("from an earlier version of its input (size or modification time differ)")
    old_recipe = old.get("recipe", {}) if isinstance(old.get("recipe"), dict) else {}
    for key, value in new["recipe"].items():
        if old_recipe.get(key) != value:
            out.append(f"with {key} {json.dumps(old_recipe.get(key))} (now {json.dumps(value)})")
    return out


class Ledger:
    """The records of one ``--out`` folder: read once at the start, appended as inputs are written.

    Parameters
    ----------
    out : path-like
        The output folder (its ledger may not exist yet).
    """

    def __init__(self, out: str | os.PathLike) -> None:
        self.out = Path(out)
        self.path = self.out / LEDGER
        self._by_output: dict[str, dict[str, Any]] = {}
        lines = self._read()
        for record in lines:
            for rel in record["outputs"]:
                self._by_output[rel] = record
        if len(lines) > 2 * len({id(r) for r in self._by_output.values()}) + 64:
            self._compact()  # reruns with --overwrite append again: keep the file the size of its content

    def _read(self) -> list[dict[str, Any]]:
        if not os.path.lexists(self.path):
            return []
        text = read_text(self.path, "fill ledger", limit=MAX_JSON_BYTES, follow_links=False)
        records = []
        for line in text.splitlines():
            try:
                record = loads_json(line, "fill ledger line")
            except InpaintenvError:
                continue  # a line cut short by a kill
            # A line of another shape (outputs that are not paths: a tampered or foreign line) records nothing.
            if isinstance(record, dict) and isinstance(record.get("outputs"), list) and isinstance(
                    record.get("input"), dict) and all(isinstance(o, str) for o in record["outputs"]):
                records.append(record)
        return records

    def _compact(self) -> None:
        unique = {id(r): r for r in self._by_output.values()}.values()
        write_text_atomic(self.path, "".join(json.dumps(r) + "\n" for r in unique), "fill ledger")

    def _rel(self, path: Path) -> str:
        return path.relative_to(self.out).as_posix()

    def conflict(self, job: FillJob, record: dict[str, Any]) -> str | None:
        """Why ``job`` may not write over an output already there (None: none is there, or all are its own)."""
        for path in job.all_outputs:
            if not os.path.lexists(path):
                continue
            old = self._by_output.get(self._rel(path))
            if old is None:
                return (f"{path} exists and was not written by inpaintenv fill into this --out (no record in "
                        f"{self.path.name}); not replaced: give --overwrite to replace it, or another --out")
            diff = _differences(old, record)
            if diff:
                made = "was being made" if old.get("intent") is True else "was made"
                return (f"{path} exists and {made} {'; '.join(diff)}; not replaced: give --overwrite to "
                        "redo it, or another --out")
        return None

    def done(self, job: FillJob) -> bool:
        """Whether every output of ``job`` is there and its latest line is a record, not an intent
        (a run killed between an input's outputs left an intent: the input is redone)."""
        for path in job.all_outputs:
            old = self._by_output.get(self._rel(path))
            if not os.path.lexists(path) or (old is not None and old.get("intent") is True):
                return False
        return True

    def new_record(self, job: FillJob, recipe: dict[str, Any]) -> dict[str, Any]:
        """The record of ``job`` made by ``recipe`` (its input's identity taken now, before it is read)."""
        return {"outputs": [self._rel(p) for p in job.all_outputs], "input": file_identity(job.source),
                "recipe": recipe}

    def intend(self, record: dict[str, Any]) -> None:
        """Append ``record`` as an intent (before the first of its outputs is written)."""
        self.record({**record, "intent": True})

    def record(self, record: dict[str, Any]) -> None:
        """Append ``record`` (after its outputs are written); never through a link."""
        append_text(self.path, json.dumps(record) + "\n", "fill ledger")
        for rel in record["outputs"]:
            self._by_output[rel] = record
