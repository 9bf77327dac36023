"""Benchmark reports: a study-style table with bootstrap intervals, JSON, CSV, Markdown."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

from ..report.provenance import environment_info
from ..report.results import EvaluationResult, json_safe, skipped_markdown
from ..files import write_text_atomic
from ..report.tables import REPORT_METRICS, summary_table, table_to_csv, to_markdown
from .density import density_markdown, density_table
from .headline import (
    every_method_markdown, every_method_vs_strongest, headline_markdown, headline_title, learned_vs_classical,
)
from ..files.ownership import claim

__all__ = ["REPORT_METRICS", "summary_table", "table_keys", "to_markdown", "environment_info", "write_report"]


def table_keys(result: EvaluationResult, drive: bool = False) -> tuple[str, ...]:
    """The columns of a run's tables: method and protocol (and drive), with the input kind between
    them when some row is of a single scan (rect-v1 on maps and on scans are different tasks)."""
    scans = any(r.get("input_kind", "map") != "map" for r in result.rows)
    keys = ("method", "input_kind", "protocol") if scans else ("method", "protocol")
    return keys + (("drive",) if drive else ())


def write_report(
    result: EvaluationResult, out_dir: str | os.PathLike, *, meta: dict[str, Any] | None = None
) -> dict[str, Path]:
    """Write the report of a run into ``out_dir``.

    ``results.json`` (every per-frame row, the tables, the headline, the environment, and
    ``skipped_frames``: unreadable frames left out, with the reason),
    ``results.csv`` (per-frame rows), ``table.csv`` / ``by_drive.csv`` (the tables: mean,
    interval bounds and frames in the mean per metric; empty bounds where no interval
    exists) and ``results.md`` (overall and per-drive tables, and the best learned vs
    strongest classical comparison of :mod:`.headline` when the run has both kinds, and the
    table by LiDAR density of :mod:`.density` when the run scored scans at several densities).

    Each file is written whole or not at all (a full disk leaves the previous one), and
    only over a file a run recorded writing (:mod:`.ownership`): ``out_dir`` must be
    empty, new or a run folder.

    Raises
    ------
    ForeignFolderError
        If ``out_dir`` holds files that no run wrote (see :mod:`.ownership`).
    OSError
        If a file cannot be written (the message names it).

    Returns
    -------
    dict of str to Path
        Paths of the written files by kind (``json``, ``csv``, ``table_csv``,
        ``by_drive_csv``, ``markdown``).
    """
    out = Path(out_dir)
    keys, drive_keys = table_keys(result), table_keys(result, drive=True)
    table = summary_table(result, keys)
    per_drive = summary_table(result, drive_keys)
    headline = learned_vs_classical(result)
    every = every_method_vs_strongest(result)
    by_density = density_table(result)
    full_meta = {**result.meta, **(meta or {})}
    doc = {
        "meta": {k: v for k, v in full_meta.items() if k != "skipped_frames"},
        "skipped_frames": full_meta.get("skipped_frames") or [],
        "environment": environment_info(),
        "table": table,
        "by_drive": per_drive,
        "headline": headline,
        "vs_strongest_classical": every,
        **({"by_density": by_density} if by_density else {}),  # a run without a density axis keeps its document
        "rows": result.rows,
    }
    paths = {
        "json": out / "results.json", "csv": out / "results.csv", "table_csv": out / "table.csv",
        "by_drive_csv": out / "by_drive.csv", "markdown": out / "results.md",
    }
    # Recorded before they are written; a file of the same name that no run wrote is refused.
    claim(out, *(p.name for p in paths.values()))
    write_text_atomic(paths["json"], json.dumps(json_safe(doc), indent=1))
    result.to_csv(paths["csv"])
    table_to_csv(table, paths["table_csv"], keys)
    table_to_csv(per_drive, paths["by_drive_csv"], drive_keys)
    md = [
        "# Benchmark results",
        "",
        (f"Data: {doc['meta'].get('source', '?')}; "
         f"{'tasks' if 'tasks' in doc['meta'] else 'protocols'}: "
         f"{', '.join(doc['meta'].get('tasks') or doc['meta'].get('protocols', []))}; "
         f"seeds: {doc['meta'].get('seeds')}."),
        "",
        to_markdown(table, keys),
        "",
    ]
    if doc["skipped_frames"]:
        md += [skipped_markdown(doc["skipped_frames"]), ""]
    md += [
        "## Per drive",
        "",
        to_markdown(per_drive, drive_keys),
        "",
    ]
    if headline:
        md += [
            f"## {headline_title(headline)} (per protocol and drive)",
            "",
            "Ratio of mean hole RMSE (under densify-v1: RMSE on the ground-truth pixels the scan did not "
            "measure) on the frame-masks both methods scored, with a paired 95 % bootstrap interval; the last "
            "column is the first method's all-pixel RMSE ÷ the classical method's RMSE of the task.",
            "",
            headline_markdown(headline),
            "",
        ]
    if by_density:
        md += ["## By LiDAR density", "",
               "Mean RMSE (m) of each task's pixels over its frames at every scan density the run scored: the hole, "
               "under densify-v1 the ground-truth pixels the input did not measure (sparser inputs leave more of "
               "them, farther from a measurement).", "", density_markdown(by_density), ""]
    if every:
        md += ["## Every method vs the strongest classical (all drives pooled)", "", every_method_markdown(every), ""]
    write_text_atomic(paths["markdown"], "\n".join(md))
    return paths
