"""The headline comparison of a benchmark run: best learned method vs strongest classical one.

The project's claim is a ratio measured per drive and protocol in one run: the learned
method with the lowest hole RMSE divided by the classical method with the lowest hole
RMSE, on the same frames and masks. This module computes it from the per-frame rows,
with a paired bootstrap interval (frames and masks resampled together for both
methods), and the second condition: the learned method's all-pixel RMSE divided by the
classical method's hole RMSE.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np

from ..evaluate import EvaluationResult
from ..report.stats import bootstrap_ratio_ci
from ..report.tables import TRAINED_MARK, interval_cell, table_notes, trained_note
from .suites import CLASSICAL, STUDY_CLASSICAL

__all__ = ["CLASSICAL_METHODS", "learned_vs_classical", "headline_markdown"]

#: Methods counted as classical; every other method in a run counts as learned.
CLASSICAL_METHODS: frozenset[str] = frozenset(CLASSICAL + STUDY_CLASSICAL)


def _per_frame(rows: Iterable[dict[str, Any]], metric: str) -> dict[tuple, float]:
    out = {}
    for r in rows:
        value = r.get(metric)
        if r["hole_count"] and value is not None and np.isfinite(value):
            out[(r["seed"], r["index"])] = float(value)
    return out


def learned_vs_classical(
    result: EvaluationResult,
    *,
    classical: Iterable[str] = CLASSICAL_METHODS,
    keys: Sequence[str] = ("protocol", "drive"),
    confidence: float = 0.95,
    n_resamples: int = 2000,
    seed: int = 0,
) -> list[dict[str, Any]]:
    """Best learned vs strongest classical method per ``keys`` group (default: protocol and drive).

    Parameters
    ----------
    result : EvaluationResult
        Per-frame rows of a run (``method``, ``seed``, ``index``, ``hole_rmse``,
        ``all_rmse``, ``hole_count`` and the ``keys`` columns).
    classical : iterable of str
        Names counted as classical (default :data:`CLASSICAL_METHODS`); the rest are learned.
    keys : sequence of str
        Row columns that define a comparison group.
    confidence, n_resamples, seed
        Paired percentile bootstrap of the hole-RMSE ratio over the frame-masks both
        methods scored.

    Returns
    -------
    list of dict
        One entry per group that has at least one method of each kind: the ``keys``,
        ``learned`` / ``classical`` (method names), their mean ``*_hole_rmse``,
        ``hole_ratio`` with ``hole_ratio_low`` / ``hole_ratio_high`` (NaN from a single
        frame) and ``hole_ratio_n`` (frame-masks in the paired comparison),
        ``all_over_classical_hole`` (learned all-pixel RMSE ÷ classical hole RMSE),
        ``n_frames`` (frame-masks both methods scored) and ``n_skipped_hole`` (those of
        them without ground truth in their hole, left out), as in every table, and
        ``learned_trained_on``: the group's drives that were in the learned method's
        training data (``result.meta["training_drives"]``; empty when none or unknown).
    """
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence}")
    classical = frozenset(classical)
    trained = result.meta.get("training_drives") or {}
    groups: dict[tuple, dict[str, list[dict[str, Any]]]] = {}
    for row in result.rows:
        groups.setdefault(tuple(row[k] for k in keys), {}).setdefault(row["method"], []).append(row)
    out = []
    for group, by_method in groups.items():
        hole = {m: _per_frame(rows, "hole_rmse") for m, rows in by_method.items()}
        mean = {m: float(np.mean(list(v.values()))) for m, v in hole.items() if v}
        learned = [m for m in mean if m not in classical]
        strong = [m for m in mean if m in classical]
        if not learned or not strong:
            continue
        best_l = min(learned, key=mean.__getitem__)
        best_c = min(strong, key=mean.__getitem__)
        shared = sorted(set(hole[best_l]) & set(hole[best_c]))
        both = {(r["seed"], r["index"]) for r in by_method[best_l]} & {
            (r["seed"], r["index"]) for r in by_method[best_c]
        }
        if not shared:
            continue
        a = np.array([hole[best_l][k] for k in shared])
        b = np.array([hole[best_c][k] for k in shared])
        ratio, low, high = bootstrap_ratio_ci(a, b, confidence=confidence, n_resamples=n_resamples, seed=seed)
        learned_all = _per_frame(by_method[best_l], "all_rmse")
        all_mean = float(np.mean([learned_all[k] for k in shared if k in learned_all]))
        out.append({
            **dict(zip(keys, group)),
            "learned": best_l, "learned_hole_rmse": float(a.mean()),
            "classical": best_c, "classical_hole_rmse": float(b.mean()),
            "hole_ratio": float(ratio), "hole_ratio_low": float(low), "hole_ratio_high": float(high),
            "hole_ratio_n": len(shared),
            "all_over_classical_hole": all_mean / float(b.mean()),
            "n_frames": len(both), "n_skipped_hole": len(both) - len(shared),
            "learned_trained_on": sorted({str(r["drive"]) for r in by_method[best_l]} & set(trained.get(best_l) or ())),
        })
    return out


def headline_markdown(rows: list[dict[str, Any]], keys: Sequence[str] = ("protocol", "drive")) -> str:
    """Markdown table of :func:`learned_vs_classical`, notes underneath (empty string when
    there is nothing to compare).

    ``frames`` and ``skipped`` count as in every table; the ratio follows the interval rule
    of :func:`inpaintenv.report.tables.interval_cell`.
    """
    if not rows:
        return ""
    heads = list(keys) + ["frames", "skipped", "best learned (hole RMSE m)", "strongest classical (hole RMSE m)",
                          "ratio [95 % CI]", "learned all ÷ classical hole"]
    lines = [
        "| " + " | ".join(heads) + " |",
        "|" + "|".join(["---"] * len(keys) + ["---:"] * 2 + ["---"] * 2 + ["---:"] * 2) + "|",
    ]
    ratios = []
    learned_cells = []
    for r in rows:
        ratios.append(interval_cell(
            r["hole_ratio"], r["hole_ratio_low"], r["hole_ratio_high"], r["hole_ratio_n"], ".2f", brackets=True
        ))
        mark = f" {TRAINED_MARK}" if r.get("learned_trained_on") else ""
        learned_cells.append(f"{r['learned']}{mark} {r['learned_hole_rmse']:.2f}")
        lines.append("| " + " | ".join([str(r[k]) for k in keys] + [
            str(r["n_frames"]),
            str(r["n_skipped_hole"]),
            learned_cells[-1],
            f"{r['classical']} {r['classical_hole_rmse']:.2f}",
            ratios[-1],
            f"{r['all_over_classical_hole']:.2f}",
        ]) + " |")
    notes = table_notes(
        ratios, frames="frame-masks both methods scored",
        values="ratio of the mean hole RMSEs [paired 95 % percentile-bootstrap interval] (2,000 resamples, seed 0)",
    )
    return "\n".join(lines + [""] + notes + trained_note(learned_cells))
