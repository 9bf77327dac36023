"""Benchmark reports: a study-style table with bootstrap intervals, JSON, CSV, Markdown."""

from __future__ import annotations

import json
import math
import os
import platform
import sys
from collections.abc import Sequence
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

from ..evaluate import EvaluationResult, json_safe
from .headline import headline_markdown, learned_vs_classical
from .stats import bootstrap_mean_ci

__all__ = ["REPORT_METRICS", "summary_table", "to_markdown", "environment_info", "write_report"]

#: (key, header, format) of the Markdown table: the study's Table I/II columns first.
REPORT_METRICS: tuple[tuple[str, str, str], ...] = (
    ("hole_rmse", "hole RMSE (m)", ".2f"),
    ("hole_psnr", "hole PSNR (dB)", ".1f"),
    ("all_rmse", "all RMSE (m)", ".2f"),
    ("all_psnr", "all PSNR (dB)", ".1f"),
    ("hole_mae", "hole MAE (m)", ".2f"),
    ("hole_irmse", "hole iRMSE (1/km)", ".1f"),
)


def summary_table(
    result: EvaluationResult,
    keys: Sequence[str] = ("method", "protocol"),
    *,
    confidence: float = 0.95,
    seed: int = 0,
) -> list[dict[str, Any]]:
    """Mean over frames with a bootstrap interval for every report metric.

    Each entry holds the ``keys``, ``n_frames``, ``n_skipped_hole``, ``ms_per_frame``
    and, per metric, ``{metric}`` (the mean), ``{metric}_low`` and ``{metric}_high``.
    Frames without ground truth in their hole are left out of every metric.
    """
    groups: dict[tuple, list[dict[str, Any]]] = {}
    for row in result.rows:
        groups.setdefault(tuple(row[k] for k in keys), []).append(row)
    table = []
    for key, rows in groups.items():
        entry: dict[str, Any] = dict(zip(keys, key))
        entry["n_frames"] = len(rows)
        entry["n_skipped_hole"] = sum(1 for r in rows if not r["hole_count"])
        for metric, _, _ in REPORT_METRICS:
            # Frames without ground truth in their hole leave every mean (see metrics.aggregate).
            vals = np.array(
                [np.nan if r[metric] is None or not r["hole_count"] else r[metric] for r in rows], dtype=float
            )
            mean, low, high = bootstrap_mean_ci(vals, confidence=confidence, seed=seed)
            entry[metric], entry[f"{metric}_low"], entry[f"{metric}_high"] = mean, low, high
        entry["hole_fraction"] = float(np.mean([r["hole_fraction"] for r in rows]))
        entry["ms_per_frame"] = float(np.mean([r["ms"] for r in rows]))
        table.append(entry)
    return table


def _cell(entry: dict[str, Any], metric: str, fmt: str) -> str:
    mean = entry.get(metric)
    if mean is None or (isinstance(mean, float) and math.isnan(mean)):
        return "–"
    half = max(entry[f"{metric}_high"] - mean, mean - entry[f"{metric}_low"])
    return f"{format(mean, fmt)} ± {format(half, fmt)}"


def to_markdown(table: list[dict[str, Any]], keys: Sequence[str] = ("method", "protocol")) -> str:
    """Markdown laid out like the study's tables: mean ± half-width of the 95 % interval."""
    heads = list(keys) + ["frames"] + [h for _, h, _ in REPORT_METRICS] + ["ms/frame"]
    lines = ["| " + " | ".join(heads) + " |", "|" + "|".join(["---"] * len(keys) + ["---:"] * (len(heads) - len(keys))) + "|"]
    for entry in table:
        cells = [str(entry[k]) for k in keys] + [str(entry["n_frames"])]
        cells += [_cell(entry, m, f) for m, _, f in REPORT_METRICS]
        cells.append(f"{entry['ms_per_frame']:.1f}")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def environment_info() -> dict[str, Any]:
    """Versions and machine facts recorded beside every result."""
    versions = {}
    for dist in ("inpaintenv", "numpy", "opencv-python-headless", "scikit-learn", "gymnasium", "torch", "joblib"):
        try:
            versions[dist] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            versions[dist] = None
    info: dict[str, Any] = {
        "python": sys.version.split()[0],
        "platform": platform.platform(),
        "processor": platform.machine(),
        "cpu_count": os.cpu_count(),
        "versions": versions,
    }
    torch = sys.modules.get("torch")  # only report a device if a method loaded torch
    if torch is not None:
        info["torch_threads"] = torch.get_num_threads()
        info["cuda"] = bool(torch.cuda.is_available())
        if torch.cuda.is_available():
            info["cuda_device"] = torch.cuda.get_device_name(0)
    return info


def write_report(
    result: EvaluationResult, out_dir: str | os.PathLike, *, meta: dict[str, Any] | None = None
) -> dict[str, Path]:
    """Write ``results.json`` (every per-frame row, tables, environment), ``results.csv``
    (per-frame rows) and ``results.md`` (overall and per-drive tables, and the best learned
    vs strongest classical comparison of :mod:`.headline` when the run has both kinds).

    Returns
    -------
    dict of str to Path
        Paths of the written files by kind.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    table = summary_table(result)
    per_drive = summary_table(result, ("method", "protocol", "drive"))
    headline = learned_vs_classical(result)
    doc = {
        "meta": {**result.meta, **(meta or {})},
        "environment": environment_info(),
        "table": table,
        "by_drive": per_drive,
        "headline": headline,
        "rows": result.rows,
    }
    paths = {"json": out / "results.json", "csv": out / "results.csv", "markdown": out / "results.md"}
    paths["json"].write_text(json.dumps(json_safe(doc), indent=1))
    result.to_csv(paths["csv"])
    md = [
        "# Benchmark results",
        "",
        f"Data: {doc['meta'].get('source', '?')}; protocols: {', '.join(doc['meta'].get('protocols', []))}; "
        f"seeds: {doc['meta'].get('seeds')}. Mean over frames ± half-width of the 95 % bootstrap interval.",
        "",
        to_markdown(table),
        "",
        "## Per drive",
        "",
        to_markdown(per_drive, ("method", "protocol", "drive")),
        "",
    ]
    if headline:
        md += [
            "## Best learned vs strongest classical (per protocol and drive)",
            "",
            "Ratio of mean hole RMSE on the frame-masks both methods scored, with a paired "
            "95 % bootstrap interval; the last column is the learned method's all-pixel RMSE "
            "÷ the classical method's hole RMSE.",
            "",
            headline_markdown(headline),
            "",
        ]
    paths["markdown"].write_text("\n".join(md))
    return paths
