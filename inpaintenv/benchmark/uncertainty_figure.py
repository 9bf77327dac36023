"""``uncertainty.png``: the reliability diagram and the sparsification errors of every method with an interval.

Drawn from the rows alone (their ``coverage_50`` ... ``coverage_95``, ``ause_rmse`` and
``aurg_rmse`` columns; :mod:`inpaintenv.metrics._sparsification` defines them): left, the
coverage at each nominal level in both conventions (solid: the mean over frames, per image;
dashed: every pixel pooled, each frame's coverage weighed by its scored pixels, which is
exact for a share); right, each method's per-image AUSE and AURG (RMSE, metres).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..metrics import CALIBRATION_LEVELS, task_of
from ..report import style
from ..report.results import EvaluationResult

__all__ = ["COVERAGE_COLUMNS", "has_reliability", "plot_uncertainty"]

#: The row columns of the reliability diagram, one per nominal level.
COVERAGE_COLUMNS = tuple(f"coverage_{round(c * 100)}" for c in CALIBRATION_LEVELS)


def _finite(v: Any) -> bool:
    return v is not None and np.isfinite(v)


def has_reliability(result: EvaluationResult) -> bool:
    """Whether some row carries the reliability diagram's columns (so ``uncertainty.png`` is drawn)."""
    return any(_finite(r.get(COVERAGE_COLUMNS[0])) for r in result.rows)


def plot_uncertainty(result: EvaluationResult, path: str | Path, *, colours: Mapping[str, Any] | None = None) -> Path:
    """Reliability diagram (both conventions) and per-image AUSE/AURG per method, from the rows."""
    from .figures import _pyplot, _save

    plt = _pyplot()
    colours = colours or style.method_colours(result.methods)
    groups: dict[str, list[dict[str, Any]]] = {}
    for row in result.rows:
        if _finite(row.get(COVERAGE_COLUMNS[0])):
            groups.setdefault(row["method"], []).append(row)
    fig, (rel, bars) = plt.subplots(1, 2, figsize=(10.4, 4.6))
    levels = np.asarray(CALIBRATION_LEVELS)
    rel.plot([0.45, 1.0], [0.45, 1.0], color="0.6", linewidth=1, label="calibrated")
    names, ause, aurg = [], [], []
    for method, rows in groups.items():
        count = f"{task_of(r['hole_fraction'] for r in rows)}_count"
        cov = np.array([[r[c] for c in COVERAGE_COLUMNS] for r in rows], float)
        weight = np.array([r.get(count) or 0 for r in rows], float)
        per_image = np.nanmean(cov, axis=0)
        pooled = (np.nan_to_num(cov) * weight[:, None]).sum(axis=0) / max(weight.sum(), 1.0)
        colour = colours.get(method)
        rel.plot(levels, per_image, marker="o", color=colour, label=f"{method}, per image")
        rel.plot(levels, pooled, marker="s", linestyle="--", color=colour, label=f"{method}, pixels pooled")
        names.append(method)
        ause.append(np.nanmean([r.get("ause_rmse", np.nan) for r in rows]))
        aurg.append(np.nanmean([r.get("aurg_rmse", np.nan) for r in rows]))
    rel.set_xlabel("nominal coverage")
    rel.set_ylabel("share of the task's truths inside the interval")
    rel.set_title("reliability diagram (above the diagonal: too wide)", fontsize=9)
    rel.grid(alpha=0.3)
    rel.legend(fontsize=7)
    x = np.arange(len(names))
    bars.bar(x - 0.2, ause, width=0.4, label="AUSE (lower is better)", color="tab:red")
    bars.bar(x + 0.2, aurg, width=0.4, label="AURG (higher is better)", color="tab:blue")
    bars.set_xticks(x, names, fontsize=7, rotation=20)
    bars.set_ylabel("area, RMSE-based (m), mean over frames")
    bars.set_title("sparsification by interval width, per image (Poggi et al.)", fontsize=9)
    bars.grid(alpha=0.3, axis="y")
    bars.legend(fontsize=7)
    frames = sum(len(r) for r in groups.values())
    fig.suptitle(f"per-pixel intervals: {frames} frame-masks with intervals, from the rows", fontsize=10)
    fig.tight_layout()
    return _save(fig, path, dpi=100)
