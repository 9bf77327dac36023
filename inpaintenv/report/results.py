"""The result of an evaluation: per-frame rows, aggregate tables, JSON / CSV / Markdown.

:class:`EvaluationResult` is what :func:`inpaintenv.evaluate.evaluate` returns and what
the benchmark's run folder stores; it is defined here, apart from the evaluation loop,
so that reading and reporting rows needs none of the loop's machinery.
"""

from __future__ import annotations

import csv
import io
import json
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..conventions import DEFAULT_MAX_DEPTH, check_max_depth
from ..metrics import EXTRA_COLUMNS, METRIC_NAMES, REGIONS, aggregate, metric_records, task_of
from . import tables
from ..files import MAX_JSON_BYTES, read_json, read_text, write_bytes_atomic, write_text_atomic
from ..exceptions import InvalidInputError, ResultRowError
from ..values.rows import UniqueRows, check_row

__all__ = [
    "ID_COLUMNS", "METRIC_COLUMNS", "ROW_COLUMNS", "EvaluationResult", "json_safe", "merge_skipped", "parse_row",
    "skipped_markdown",
]


#: Per-frame metric columns, in report order: hole and all pixels, then the unmeasured pixels and KITTI's four.
METRIC_COLUMNS: tuple[str, ...] = tuple(
    f"{r}_{m}" for r in REGIONS for m in METRIC_NAMES
) + tuple(f"{r}_count" for r in REGIONS) + EXTRA_COLUMNS


#: Identifying columns of a per-frame row, in report order (``input_kind``: ``"map"`` or ``"scan"``).
ID_COLUMNS: tuple[str, ...] = ("method", "protocol", "input_kind", "seed", "index", "frame_id", "drive")


#: All per-frame columns, in report order.
ROW_COLUMNS: tuple[str, ...] = ID_COLUMNS + ("hole_fraction",) + METRIC_COLUMNS + ("ms",)


def _mean(values: Iterable[float]) -> float:
    vals = [v for v in values if v is not None and not math.isnan(v)]
    return float(np.mean(vals)) if vals else float("nan")


@dataclass
class EvaluationResult:
    """Per-frame rows and the aggregate table of one or more evaluations.

    Attributes
    ----------
    rows : list of dict
        One row per (method, seed, frame): the columns of :data:`ROW_COLUMNS` --
        ``method``, ``protocol``, ``seed``, ``index`` (position in the source, which also
        seeds the mask), ``frame_id``, ``drive``, ``hole_fraction`` (occluded share of
        the frame), every metric of :func:`~inpaintenv.metrics.frame_metrics` (hole
        metrics are NaN when the hole holds no valid ground truth), and ``ms`` (wall
        clock of the method per frame; a batch's time is split evenly over its frames).
    meta : dict
        How the rows were produced (source, protocol, seeds, max_depth, version).
    """

    rows: list[dict[str, Any]]
    meta: dict[str, Any] = field(default_factory=dict)

    # -- aggregation -------------------------------------------------------------------
    def group_table(self, keys: Sequence[str] = ("method", "protocol")) -> list[dict[str, Any]]:
        """Aggregate the rows grouped by ``keys`` (mean over frames).

        Each output row holds the key values, :func:`inpaintenv.metrics.aggregate`'s
        result (``{region}_{metric}``, ``n_frames``, ``n_skipped_hole``), the mean
        ``hole_fraction`` and ``ms_per_frame``, and the mean of every other metric record's
        column (intervals, computed metrics: :func:`~inpaintenv.metrics.metric_records`) some
        row of the group has.
        Groups keep the order of first appearance.
        """
        groups: dict[tuple, list[dict[str, Any]]] = {}
        for row in self.rows:
            groups.setdefault(tuple(row[k] for k in keys), []).append(row)
        max_depth = float(self.meta.get("max_depth", DEFAULT_MAX_DEPTH))
        table = []
        for key, rows in groups.items():
            # Rows of runs made before the unmeasured and KITTI columns existed lack them; every other
            # metric record (intervals, evaluate's computed metrics) is pooled where some row has it.
            columns = [*METRIC_COLUMNS, *_record_columns(rows)]
            metrics = [{c: row.get(c, math.nan) for c in columns} for row in rows]
            agg = aggregate(metrics, how="mean", max_depth=max_depth, task=task_of(r["hole_fraction"] for r in rows))
            entry: dict[str, Any] = dict(zip(keys, key))
            entry.update(agg)
            entry["n_frames"] = int(agg["n_frames"])
            entry["hole_fraction"] = _mean(r["hole_fraction"] for r in rows)
            entry["ms_per_frame"] = _mean(r["ms"] for r in rows)
            table.append(entry)
        return table

    @property
    def table(self) -> list[dict[str, Any]]:
        """One aggregate row per (method, protocol): mean over all frames and seeds."""
        return self.group_table(("method", "protocol"))

    def by_drive(self) -> list[dict[str, Any]]:
        """One aggregate row per (method, protocol, drive)."""
        return self.group_table(("method", "protocol", "drive"))

    def by_seed(self) -> list[dict[str, Any]]:
        """One aggregate row per (method, protocol, seed)."""
        return self.group_table(("method", "protocol", "seed"))

    @property
    def methods(self) -> list[str]:
        """Method names in order of appearance."""
        return list(dict.fromkeys(r["method"] for r in self.rows))

    @classmethod
    def concat(cls, results: Sequence[EvaluationResult]) -> EvaluationResult:
        """Join several results (e.g. one per method) into one."""
        if not results:
            raise InvalidInputError("no results to concatenate")
        rows = [row for r in results for row in r.rows]
        meta = dict(results[0].meta)
        meta["methods"] = list(dict.fromkeys(m for r in results for m in r.meta.get("methods", [])))
        protocols = list(dict.fromkeys(r.meta["protocol"] for r in results if "protocol" in r.meta))
        if len(protocols) > 1:
            meta["protocol"] = protocols
        seeds = list(dict.fromkeys(s for r in results for s in r.meta.get("seeds", [])))
        if seeds:
            meta["seeds"] = seeds
        skipped = merge_skipped(r.meta.get("skipped_frames") or [] for r in results)
        if skipped:
            meta["skipped_frames"] = skipped
        if any("interval_methods" in r.meta for r in results):
            meta["interval_methods"] = list(dict.fromkeys(m for r in results for m in r.meta.get("interval_methods", [])))
        trained = {k: v for r in results for k, v in (r.meta.get("training_drives") or {}).items()}
        if trained:
            meta["training_drives"] = trained
        return cls(rows=rows, meta=meta)

    # -- output ------------------------------------------------------------------------
    def to_json(self, path: str | Path) -> Path:
        """Write ``{"meta", "skipped_frames", "table", "by_drive", "rows"}`` as JSON (NaN written as null).

        ``table`` and ``by_drive`` are :func:`inpaintenv.report.tables.summary_table` entries:
        means with interval bounds (null when undefined) and the frames in each mean.
        ``skipped_frames`` lists the unreadable frames left out (``on_bad_frame="skip"``)
        with the reason; it is empty when none were.
        """
        path = Path(path)
        doc = {
            "meta": {k: v for k, v in self.meta.items() if k != "skipped_frames"},
            "skipped_frames": self.meta.get("skipped_frames") or [],
            "table": tables.summary_table(self),
            "by_drive": tables.summary_table(self, ("method", "protocol", "drive")),
            "rows": self.rows,
        }
        return write_text_atomic(path, json.dumps(json_safe(doc), indent=1))

    @classmethod
    def from_json(cls, path: str | Path) -> EvaluationResult:
        """Read a result written by :meth:`to_json`; every row is checked (:func:`parse_row`), one per key.

        Raises
        ------
        InvalidInputError
            If the file is not a results.json of inpaintenv, or a row is not a possible one
            (:class:`~inpaintenv.exceptions.ResultRowError`, naming the file and the row).
        """
        doc = read_json(path, "results file")  # bounded in size and nesting; a FIFO is refused at once
        if not isinstance(doc, dict) or not isinstance(doc.get("rows"), list) or not all(
                isinstance(r, dict) for r in doc["rows"]) or not isinstance(doc.get("meta", {}), dict):
            raise InvalidInputError(f"{path} is not a results.json of inpaintenv (an object whose meta is an object "
                                    "and whose rows are objects)")
        meta = dict(doc.get("meta", {}))
        max_depth = _max_depth_of(meta, path)
        rows = _parse_rows(doc["rows"], path, max_depth=max_depth)
        if doc.get("skipped_frames"):
            meta["skipped_frames"] = doc["skipped_frames"]
        return cls(rows=rows, meta=meta)

    def to_csv(self, path: str | Path) -> Path:
        """Write the per-frame rows as CSV (NaN written as an empty cell), whole or not at all.

        Columns: :data:`ROW_COLUMNS`, and the interval columns when some row has them (a
        row without them leaves their cells empty).
        """

        # The interval columns only when some row has them (before "ms"), so runs without
        # intervals write the file they always wrote.
        columns = list(ROW_COLUMNS[:-1]) + _record_columns(self.rows) + [ROW_COLUMNS[-1]]

        text = io.StringIO(newline="")
        writer = csv.DictWriter(text, fieldnames=columns, extrasaction="ignore")
        writer.writeheader()
        for row in self.rows:
            writer.writerow({k: _csv_cell(row.get(k, math.nan)) for k in columns})
        return write_bytes_atomic(path, text.getvalue().encode("utf-8"))

    @classmethod
    def from_csv(cls, path: str | Path) -> EvaluationResult:
        """Read per-frame rows written by :meth:`to_csv` (``meta`` is empty)."""
        # A results CSV is as large as its results.json can be; a FIFO is refused at once.
        text = read_text(path, "results CSV", limit=MAX_JSON_BYTES)
        rows = _parse_rows(csv.DictReader(io.StringIO(text, newline="")), path, text=True)
        return cls(rows=rows, meta={})

    def to_markdown(
        self, table: list[dict[str, Any]] | None = None, *, keys: Sequence[str] | None = None
    ) -> str:
        """The table of these rows as Markdown, in the one format of every table.

        Means over frames with their 95 % bootstrap interval, units in the header,
        ``frames`` and ``skipped`` columns and the notes explaining them underneath (see
        :func:`inpaintenv.report.tables.to_markdown`).

        Parameters
        ----------
        table : list of dict, optional
            An aggregate table of these rows (e.g. :meth:`by_drive`); only its grouping
            is used: ``method``, ``protocol`` and whichever of ``drive``, ``seed`` it has.
        keys : sequence of str, optional
            Row columns to group by instead (default ``("method", "protocol")``).
        """
        if keys is None:
            extra = [k for k in ("drive", "seed") if table and k in table[0]]
            keys = ("method", "protocol", *extra)
        return tables.to_markdown(tables.summary_table(self, keys), keys)

    def __repr__(self) -> str:
        return f"EvaluationResult({len(self.rows)} rows, methods={self.methods})"


def _record_columns(rows: Sequence[dict[str, Any]]) -> list[str]:
    """The metric records' columns beyond :data:`METRIC_COLUMNS` some row has, in the records' order."""
    present = {c for row in rows for c in row}
    return [r.name for r in metric_records() if r.name in present and r.name not in METRIC_COLUMNS]


def merge_skipped(lists: Iterable[Sequence[dict[str, Any]]]) -> list[dict[str, Any]]:
    """Skipped-frame records of several results, one per frame, by frame index."""
    merged: dict[int, dict[str, Any]] = {}
    for records in lists:
        for rec in records:
            merged.setdefault(int(rec["index"]), dict(rec))
    return [merged[i] for i in sorted(merged)]


def skipped_markdown(skipped: Sequence[dict[str, Any]]) -> str:
    """The skipped frames as a Markdown list (empty string when none were skipped)."""
    if not skipped:
        return ""
    n = len(skipped)
    lines = [f"Unreadable frames left out: {n} (--on-bad-frame skip; not counted in frames or skipped):", ""]
    lines += [f"- frame {r['index']} ({r['frame_id']}): {r['reason']}" for r in skipped]
    return "\n".join(lines)


def json_safe(obj: Any) -> Any:
    """``obj`` with every float NaN replaced by None (valid JSON), recursively."""
    if isinstance(obj, float) and math.isnan(obj):
        return None
    if isinstance(obj, dict):
        return {k: json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_safe(v) for v in obj]
    return obj


def _csv_cell(v: Any) -> Any:
    if isinstance(v, float) and math.isnan(v):
        return ""
    return v


def parse_row(raw: dict[str, Any], *, max_depth: float = DEFAULT_MAX_DEPTH, text: bool = False) -> dict[str, Any]:
    """A row read back from JSON (or a CSV record, ``text=True``) with its column types restored, if it is a
    possible row (:func:`inpaintenv.values.rows.check_row`, which raises ResultRowError naming the column)."""
    return check_row(raw, max_depth=max_depth, text=text)


def _parse_rows(raws: Iterable[Any], path: str | Path, **kw: Any) -> list[dict[str, Any]]:
    """Every row of the file ``path``, checked, one per key; ResultRowError naming the file and row."""
    rows, unique = [], UniqueRows()
    for number, raw in enumerate(raws, 1):
        where = f"row {number} of {path}"
        try:
            row = parse_row(raw, **kw)
            unique.add(row, where)
        except ResultRowError as exc:
            raise ResultRowError(f"{where} is not a possible result row: {exc}") from None
        rows.append(row)
    return rows


def _max_depth_of(meta: dict[str, Any], path: str | Path) -> float:
    """The PSNR range a results file says its rows were scored with (80 m when it does not say)."""
    return check_max_depth(meta.get("max_depth", DEFAULT_MAX_DEPTH), f"meta.max_depth of {path}")
