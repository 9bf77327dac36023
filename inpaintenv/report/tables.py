"""The one table format of the package: ``evaluate``'s and the benchmark's.

:func:`summary_table` turns per-frame rows into one entry per group (mean over frames
with a percentile-bootstrap interval, the frames that entered each mean, the skipped
frames); :func:`to_markdown` lays entries out with units in the header and explains
``frames``, ``skipped`` and the interval marks under the table. :func:`interval_cell`
writes one value with its interval, by the rule every table follows:

* no interval from one frame: ``15.30 (n=1)``, and ``null`` bounds in JSON / CSV;
* an interval from fewer than :data:`~inpaintenv.report.stats.FEW_FRAMES` frames is marked ``†``;
* a method scored on drives it was trained on (``meta["training_drives"]``) is marked
  :data:`TRAINED_MARK` (with "k of n drives" when the row pools several drives), and its
  entry lists them under ``trained_on``.
"""

from __future__ import annotations

import csv
import io
import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from ..files import write_bytes_atomic
from ..metrics import metric_records, task_of
from .stats import FEW_FRAMES, bootstrap_mean_ci

__all__ = [
    "FEW_MARK", "INTERVAL_REPORT_METRICS", "REPORT_METRICS", "SCAN_REPORT_METRICS", "TRAINED_MARK", "interval_cell", "method_cell", "summary_table", "table_notes",
    "table_to_csv", "to_markdown", "trained_note",
]

class Rows(Protocol):
    """What a table is made from: per-frame rows, their meta and their grouped means.

    :class:`~inpaintenv.report.results.EvaluationResult` is one; naming the shape here
    instead of importing it keeps this module below the results (results import tables,
    never the other way, not even for typing).
    """

    rows: list[dict[str, Any]]
    meta: dict[str, Any]

    def group_table(self, keys: Sequence[str] = ...) -> list[dict[str, Any]]: ...


def _columns(group: str) -> tuple[tuple[str, str, str], ...]:
    """(key, header with unit, format) of the metric records of table ``group``, in table order."""
    return tuple((r.name, r.label, r.fmt) for r in metric_records(group))


#: (key, header with unit, format) of every table: the study's Table I/II columns first
#: (the ``"depth"`` metric records; tables read the records when they are drawn).
REPORT_METRICS: tuple[tuple[str, str, str], ...] = _columns("depth")
#: The columns a run with per-pixel intervals adds (``evaluate(..., intervals=0.9)``), same layout.
INTERVAL_REPORT_METRICS: tuple[tuple[str, str, str], ...] = _columns("interval")
#: The columns a table of single-scan inputs adds (rows of ``input_kind`` ``"scan"``): the ground-truth
#: pixels the input did not measure (densify-v1's task), and KITTI depth completion's own four.
SCAN_REPORT_METRICS: tuple[tuple[str, str, str], ...] = _columns("scan")
#: Mark of an interval from fewer than FEW_FRAMES frames.
FEW_MARK = "†"
#: Mark of a method scored on a drive that was in its training data.
TRAINED_MARK = "‡"


def summary_table(
    result: Rows,
    keys: Sequence[str] = ("method", "protocol"),
    *,
    confidence: float = 0.95,
    seed: int = 0,
) -> list[dict[str, Any]]:
    """Mean over frames with a bootstrap interval for every report metric, per group.

    Parameters
    ----------
    result : EvaluationResult (or any :class:`Rows`)
        Per-frame rows.
    keys : sequence of str
        Row columns that define a group (e.g. ``("method", "protocol", "drive")``).
    confidence : float
        Coverage of the intervals, in (0, 1).
    seed : int
        Seed of the bootstrap resampling.

    Returns
    -------
    list of dict
        One entry per group, in order of first appearance: everything
        :meth:`EvaluationResult.group_table` holds (the ``keys``, every metric's mean,
        ``n_frames``, ``n_skipped_hole``, ``hole_fraction``, ``ms_per_frame``) and, per
        metric of :data:`REPORT_METRICS` (and of :data:`INTERVAL_REPORT_METRICS` when some
        row has intervals), ``{metric}_low`` / ``{metric}_high`` (NaN when
        fewer than two frames entered the mean) and ``{metric}_n`` (frames in the mean).
        Frames without ground truth in their hole are left out of every mean. With a
        ``method`` key: ``trained_on``, the drives of the group that were in the method's
        training data (``result.meta["training_drives"]``; empty when none or unknown),
        and ``n_drives``, the drives of the group.
    """
    groups: dict[tuple, list[dict[str, Any]]] = {}
    for row in result.rows:
        groups.setdefault(tuple(row[k] for k in keys), []).append(row)
    trained = result.meta.get("training_drives") or {}
    table = result.group_table(keys)
    for entry in table:
        rows = groups[tuple(entry[k] for k in keys)]
        if len(kinds := {r.get("input_kind", "map") for r in rows}) == 1:
            entry.setdefault("input_kind", kinds.pop())  # a table of scans shows their columns (_metrics_of)
        if "method" in keys:
            drives = {str(r["drive"]) for r in rows}
            entry["n_drives"] = len(drives)
            entry["trained_on"] = sorted(drives & set(trained.get(entry["method"]) or ()))
        counted = f"{task_of(r['hole_fraction'] for r in rows)}_count"  # unmeasured_count under densify-v1
        for metric, _, _ in _metrics_of(result.rows):
            # The rule of metrics.aggregate: a frame without hole truth tested nothing.
            vals = np.array(
                [r.get(metric) if r.get(counted) and r.get(metric) is not None else np.nan for r in rows], dtype=float
            )
            _, low, high = bootstrap_mean_ci(vals, confidence=confidence, seed=seed)
            entry[f"{metric}_low"], entry[f"{metric}_high"] = low, high
            entry[f"{metric}_n"] = int(np.isfinite(vals).sum())
    return table


def _has_intervals(entries: Sequence[dict[str, Any]]) -> bool:
    """Whether some row or table entry carries an interval score."""
    return any(not _missing(e.get("hole_coverage")) for e in entries)


def _metrics_of(entries: Sequence[dict[str, Any]]) -> tuple[tuple[str, str, str], ...]:
    """:data:`REPORT_METRICS`, then :data:`SCAN_REPORT_METRICS` when some entry is of a scan input, then
    :data:`INTERVAL_REPORT_METRICS` when ``entries`` have intervals."""
    scans = any(e.get("input_kind", "map") != "map" for e in entries)
    return _columns("depth") + (_columns("scan") if scans else ()) + (
        _columns("interval") if _has_intervals(entries) else ())


def _missing(value: Any) -> bool:
    return value is None or (isinstance(value, float) and math.isnan(value))


def interval_cell(
    value: float | None, low: float | None, high: float | None, n: int, fmt: str, *, brackets: bool = False
) -> str:
    """One value with its interval, by the rule of every table.

    Parameters
    ----------
    value, low, high : float or None
        The estimate and its interval bounds (None or NaN when undefined).
    n : int
        Frames the estimate comes from.
    fmt : str
        Format of the numbers, e.g. ``".2f"``.
    brackets : bool
        ``value [low, high]`` instead of ``value ± half-width``.

    Returns
    -------
    str
        ``–`` without a value; ``value (n=1)`` without an interval; the interval followed
        by :data:`FEW_MARK` when it comes from fewer than ``FEW_FRAMES`` frames.
    """
    if _missing(value):
        return "–"
    text = format(value, fmt)
    if n < 2 or _missing(low) or _missing(high):
        return f"{text} (n={n})"
    if brackets:
        text += f" [{format(low, fmt)}, {format(high, fmt)}]"
    else:
        text += f" ± {format(max(high - value, value - low), fmt)}"
    return text + (FEW_MARK if n < FEW_FRAMES else "")


#: What the values of a table are, said under it.
MEAN_VALUES = "mean over frames ± half-width of the 95 % percentile-bootstrap interval (2,000 resamples, seed 0)"


def table_notes(
    cells: Sequence[str], *, frames: str = "(seed, frame) pairs scored", values: str = MEAN_VALUES
) -> list[str]:
    """The lines explaining a table, printed under it.

    Parameters
    ----------
    cells : sequence of str
        Every value cell of the table (the marks to explain are looked up in them).
    frames : str
        What the ``frames`` column counts.
    values : str
        What the value cells are.
    """
    notes = [
        (f"frames: {frames}; skipped: of those, the ones whose hole holds no ground truth, "
         f"left out of every mean (a mean covers frames − skipped). Values: {values}.")
    ]
    if any("(n=1)" in c for c in cells):
        notes.append("(n=1): one frame, so no interval.")
    if any(c.endswith(FEW_MARK) for c in cells):
        notes.append(
            f"{FEW_MARK} interval from fewer than {FEW_FRAMES} frames: a bootstrap from so few "
            "frames is too narrow, read it as a rough range."
        )
    return notes


def method_cell(name: str, trained_on: Sequence[str] | None, n_drives: int, per_drive: bool) -> str:
    """A method's name, marked :data:`TRAINED_MARK` when some of the drives scored were in its training data."""
    if not trained_on:
        return name
    if per_drive or len(trained_on) == n_drives == 1:
        return f"{name} {TRAINED_MARK}"
    return f"{name} {TRAINED_MARK} ({len(trained_on)} of {n_drives} drives)"


def trained_note(cells: Sequence[str]) -> list[str]:
    """The line explaining :data:`TRAINED_MARK`, if a cell carries it."""
    if not any(TRAINED_MARK in c for c in cells):
        return []
    return [(f"{TRAINED_MARK} trained on the drive scored (k of n: on k of the n drives pooled in the row): it was "
             "in the method's training data, so the row does not measure the method on unseen drives.")]


def interval_note(entries: Sequence[dict[str, Any]]) -> list[str]:
    """The line explaining the :data:`INTERVAL_REPORT_METRICS` columns, if the entries have them."""
    if not _has_intervals(entries):
        return []
    return [("Per-pixel intervals: hole coverage = share of the hole's ground truth inside the method's interval; "
             "interval width = its mean high − low; hole RMSE, 80 % most confident = over the 80 % of hole pixels "
             "with the narrowest intervals, beside the 80 % nearest the hole border (a baseline that needs no "
             "interval); rejection AUC = mean RMSE over keeping 5 %, 10 %, …, 100 % of the pixels ÷ hole RMSE "
             "(1 = no better than chance, lower is better); AUSE / AURG RMSE per image = area between the RMSE "
             "sparsification curve ranked by interval width and the oracle's (lower is better) / below random removal's "
             "(higher is better), over 0-98 % removed, per frame in metres (Poggi et al.'s convention); AUCE per image = "
             "area between the reliability diagram at nominal 50-95 % and the diagonal (lower is better); "
             "– = the method gives no interval.")]


def to_markdown(table: list[dict[str, Any]], keys: Sequence[str] = ("method", "protocol")) -> str:
    """Markdown of :func:`summary_table` entries, the notes explaining it underneath.

    Columns: the ``keys``, ``frames``, ``skipped``, the :data:`REPORT_METRICS` (units in
    the header; each cell by :func:`interval_cell`), the :data:`INTERVAL_REPORT_METRICS`
    when some entry has intervals (``–`` for a method without), and ``ms/frame``.
    """
    report = _metrics_of(table)
    heads = list(keys) + ["frames", "skipped"] + [h for _, h, _ in report] + ["ms/frame"]
    lines = [
        "| " + " | ".join(heads) + " |",
        "|" + "|".join(["---"] * len(keys) + ["---:"] * (len(heads) - len(keys))) + "|",
    ]
    values: list[str] = []
    names: list[str] = []
    for entry in table:
        metric_cells = [
            interval_cell(entry.get(m), entry.get(f"{m}_low"), entry.get(f"{m}_high"), entry.get(f"{m}_n", 0), f)
            for m, _, f in report
        ]
        values += metric_cells
        ms = entry.get("ms_per_frame")
        cells = [
            method_cell(str(entry[k]), entry.get("trained_on"), entry.get("n_drives", 0), "drive" in keys)
            if k == "method" else str(entry[k]) for k in keys
        ]
        names += cells
        cells += [str(entry["n_frames"]), str(entry["n_skipped_hole"])]
        cells += metric_cells + ["–" if _missing(ms) else f"{ms:.1f}"]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines + [""] + table_notes(values) + trained_note(names) + interval_note(table))


def table_to_csv(
    table: list[dict[str, Any]], path: str | os.PathLike, keys: Sequence[str] = ("method", "protocol")
) -> Path:
    """Write :func:`summary_table` entries as CSV; an undefined bound is an empty cell.

    Columns: the ``keys``, ``n_frames``, ``n_skipped_hole``, per metric of
    :data:`REPORT_METRICS` ``{metric}``, ``{metric}_low``, ``{metric}_high``,
    ``{metric}_n`` (also of :data:`INTERVAL_REPORT_METRICS` when some entry has intervals), then ``hole_fraction``, ``ms_per_frame`` and ``trained_on`` (the
    drives of the row in the method's training data, joined by ``;``; empty when none).
    """
    fields = list(keys) + ["n_frames", "n_skipped_hole"]
    fields += [f"{m}{s}" for m, _, _ in _metrics_of(table) for s in ("", "_low", "_high", "_n")]
    fields += ["hole_fraction", "ms_per_frame", "trained_on"]

    text = io.StringIO(newline="")
    writer = csv.DictWriter(text, fieldnames=fields, extrasaction="ignore")
    writer.writeheader()
    for entry in table:
        row = {k: "" if _missing(entry.get(k)) else entry.get(k) for k in fields}
        row["trained_on"] = ";".join(entry.get("trained_on") or [])
        writer.writerow(row)
    # Whole or not at all: a full disk leaves the previous table.
    return write_bytes_atomic(path, text.getvalue().encode("utf-8"))
