"""The headline comparison of a benchmark run: best learned method vs strongest classical one.

The project's claim is a ratio measured per drive and protocol in one run: the learned
method with the lowest hole RMSE divided by the classical method with the lowest hole
RMSE, on the same frames and masks. This module computes it from the per-frame rows,
with a paired bootstrap interval (frames and masks resampled together for both
methods), and the second condition: the learned method's all-pixel RMSE divided by the
classical method's hole RMSE.

What a method is comes from the run (``result.meta["kinds"]``, see
:func:`~inpaintenv.benchmark.suites.method_kind`): the classical methods on one side;
learned models and submitted methods (a user's own callable, a folder of predictions)
on the other, each labelled by its kind. When the strongest classical method scores
0 m, the ratio is undefined and the table says so instead of dividing by zero.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np

from ..report.results import EvaluationResult
from ..metrics import task_of
from ..report.stats import bootstrap_ratio_ci
from ..report.tables import TRAINED_MARK, interval_cell, table_notes, trained_note
from .suites import CLASSICAL, STUDY_CLASSICAL
from ..exceptions import InvalidInputError

__all__ = ["CLASSICAL_METHODS", "every_method_vs_strongest", "every_method_markdown", "headline_keys", "headline_markdown", "headline_title", "learned_vs_classical"]

#: What the ``scored on`` column says of each task.
_TASK_PIXELS = {"hole": "hole", "unmeasured": "unmeasured pixels"}

#: Methods counted as classical when the run does not say what its methods are
#: (``meta["kinds"]``); every other method then counts as learned.
CLASSICAL_METHODS: frozenset[str] = frozenset(CLASSICAL + STUDY_CLASSICAL)


def _kinds(result: EvaluationResult, classical: frozenset[str]) -> dict[str, str]:
    """Method -> its kind: the run's record, else classical by name and learned otherwise."""
    recorded = result.meta.get("kinds") or {}
    return {m: recorded.get(m) or ("classical" if m in classical else "learned") for m in result.methods}


def _undefined(classical: str) -> str:
    return f"{classical} scores 0 m in the holes: a ratio to 0 is undefined"


def _per_frame(rows: Iterable[dict[str, Any]], metric: str, task: str = "hole") -> dict[tuple, float]:
    out = {}
    for r in rows:
        value = r.get(metric)
        if r.get(f"{task}_count") and value is not None and np.isfinite(value):
            out[(r["seed"], r["index"])] = float(value)
    return out


def _task_groups(
    result: EvaluationResult, keys: Sequence[str],
) -> Iterable[tuple[tuple, dict[str, list[dict[str, Any]]], str, dict[str, dict[tuple, float]]]]:
    """Per group of ``keys``: its rows by method, its task (``metrics.task_of``) and each
    method's per-frame RMSE of that task."""
    groups: dict[tuple, dict[str, list[dict[str, Any]]]] = {}
    for row in result.rows:
        groups.setdefault(tuple(row[k] for k in keys), {}).setdefault(row["method"], []).append(row)
    for group, by_method in groups.items():
        task = task_of(r.get("hole_fraction", 1.0) for rows in by_method.values() for r in rows)
        yield group, by_method, task, {m: _per_frame(rows, f"{task}_rmse", task) for m, rows in by_method.items()}


def learned_vs_classical(
    result: EvaluationResult,
    *,
    classical: Iterable[str] = CLASSICAL_METHODS,
    keys: Sequence[str] | None = None,
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
        Names counted as classical when ``result.meta["kinds"]`` does not say what a
        method is (default :data:`CLASSICAL_METHODS`); the rest are learned.
    keys : sequence of str, optional
        Row columns that define a comparison group (default :func:`headline_keys`: protocol
        and drive, and the input kind when some row is of a scan).
    confidence, n_resamples, seed
        Paired percentile bootstrap of the hole-RMSE ratio over the frame-masks both
        methods scored.

    Each group is scored on its task's pixels (:func:`inpaintenv.metrics.task_of`): the hole,
    or under ``densify-v1`` every ground-truth pixel the scan did not measure; the ``hole_*``
    fields then hold the ``unmeasured_rmse`` figures and ``task`` says which.

    Returns
    -------
    list of dict
        One entry per group that has a classical method and another one: the ``keys``,
        ``task`` (``"hole"`` or ``"unmeasured"``),
        ``learned`` (the best method that is not classical) with ``learned_kind``
        (``"learned"`` or ``"submitted"``) and ``classical`` (method names), their mean ``*_hole_rmse``,
        ``hole_ratio`` with ``hole_ratio_low`` / ``hole_ratio_high`` (NaN from a single
        frame) and ``hole_ratio_n`` (frame-masks in the paired comparison),
        ``all_over_classical_hole`` (learned all-pixel RMSE ÷ classical hole RMSE),
        ``n_frames`` (frame-masks both methods scored) and ``n_skipped_hole`` (those of
        them without ground truth in their hole, left out), as in every table, and
        ``learned_trained_on``: the group's drives that were in the learned method's
        training data (``result.meta["training_drives"]``; empty when none or unknown).
        When the classical method's mean hole RMSE is 0, the ratios are NaN and
        ``undefined`` says why (it is absent otherwise).
    """
    if not 0.0 < confidence < 1.0:
        raise InvalidInputError(f"confidence must be in (0, 1), got {confidence}")
    keys = headline_keys(result) if keys is None else tuple(keys)
    kinds = _kinds(result, frozenset(classical))
    trained = result.meta.get("training_drives") or {}
    out = []
    for group, by_method, task, hole in _task_groups(result, keys):
        mean = {m: float(np.mean(list(v.values()))) for m, v in hole.items() if v}
        learned = [m for m in mean if kinds.get(m) != "classical"]
        strong = [m for m in mean if kinds.get(m) == "classical"]
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
        learned_all = _per_frame(by_method[best_l], "all_rmse", task)
        all_mean = float(np.mean([learned_all[k] for k in shared if k in learned_all]))
        entry: dict[str, Any] = {
            **dict(zip(keys, group)), "task": task,
            "learned": best_l, "learned_kind": kinds.get(best_l, "learned"), "learned_hole_rmse": float(a.mean()),
            "classical": best_c, "classical_hole_rmse": float(b.mean()),
        }
        if float(b.mean()) > 0.0:
            ratio, low, high = bootstrap_ratio_ci(a, b, confidence=confidence, n_resamples=n_resamples, seed=seed)
            entry.update({"hole_ratio": float(ratio), "hole_ratio_low": float(low), "hole_ratio_high": float(high),
                          "all_over_classical_hole": all_mean / float(b.mean())})
        else:  # a perfect classical fill (e.g. frames whose holes hold one depth): nothing to divide by
            entry.update({"hole_ratio": math.nan, "hole_ratio_low": math.nan, "hole_ratio_high": math.nan,
                          "all_over_classical_hole": math.nan, "undefined": _undefined(best_c)})
        entry.update({
            "hole_ratio_n": len(shared),
            "n_frames": len(both), "n_skipped_hole": len(both) - len(shared),
            "learned_trained_on": sorted({str(r["drive"]) for r in by_method[best_l]} & set(trained.get(best_l) or ())),
        })
        out.append(entry)
    return out


def headline_keys(result: EvaluationResult) -> tuple[str, ...]:
    """The columns of a headline group: protocol and drive, and first the input kind when a row is of a scan."""
    scans = any(r.get("input_kind", "map") != "map" for r in result.rows)
    return ("input_kind", "protocol", "drive") if scans else ("protocol", "drive")


def headline_title(rows: list[dict[str, Any]]) -> str:
    """``"Best learned vs strongest classical"``, naming the kinds the table compares
    (``"Best submitted ..."``, ``"Best learned or submitted ..."``)."""
    kinds = [k for k in ("learned", "submitted") if any(r.get("learned_kind", "learned") == k for r in rows)]
    return f"Best {' or '.join(kinds) or 'learned'} vs strongest classical"


def headline_markdown(rows: list[dict[str, Any]], keys: Sequence[str] | None = None) -> str:
    """Markdown table of :func:`learned_vs_classical`, notes underneath (empty string when
    there is nothing to compare).

    ``frames`` and ``skipped`` count as in every table; the ratio follows the interval rule
    of :func:`inpaintenv.report.tables.interval_cell`.
    """
    if not rows:
        return ""
    if keys is None:
        keys = [k for k in ("input_kind", "protocol", "drive") if k in rows[0]]
    best = headline_title(rows).split(" vs ")[0].lower()
    # A table holding densify-v1 names the pixels each row is scored on (its hole, or what the scan did not measure).
    mixed_tasks = any(r.get("task", "hole") != "hole" for r in rows)
    where = "" if mixed_tasks else "hole "
    heads = list(keys) + (["scored on"] if mixed_tasks else []) + [
        "frames", "skipped", f"{best} ({where}RMSE m)", f"strongest classical ({where}RMSE m)", "ratio [95 % CI]",
        f"{best.removeprefix('best ')} all ÷ classical {where or 'task '}".rstrip()]
    lines = [
        "| " + " | ".join(heads) + " |",
        "|" + "|".join(["---"] * (len(keys) + mixed_tasks) + ["---:"] * 2 + ["---"] * 2 + ["---:"] * 2) + "|",
    ]
    ratios = []
    learned_cells = []
    undefined = []
    mixed = len({r.get("learned_kind", "learned") for r in rows}) > 1
    for r in rows:
        if r.get("undefined"):
            undefined.append(r["undefined"])
            ratios.append("undefined ¶")
        else:
            ratios.append(interval_cell(
                r["hole_ratio"], r["hole_ratio_low"], r["hole_ratio_high"], r["hole_ratio_n"], ".2f", brackets=True
            ))
        mark = f" {TRAINED_MARK}" if r.get("learned_trained_on") else ""
        kind = f" ({r.get('learned_kind', 'learned')})" if mixed else ""
        learned_cells.append(f"{r['learned']}{kind}{mark} {r['learned_hole_rmse']:.2f}")
        scored = [_TASK_PIXELS[r.get("task", "hole")]] if mixed_tasks else []
        lines.append("| " + " | ".join([str(r[k]) for k in keys] + scored + [
            str(r["n_frames"]),
            str(r["n_skipped_hole"]),
            learned_cells[-1],
            f"{r['classical']} {r['classical_hole_rmse']:.2f}",
            ratios[-1],
            "undefined ¶" if r.get("undefined") else f"{r['all_over_classical_hole']:.2f}",
        ]) + " |")
    notes = table_notes(
        [c for c in ratios if not c.startswith("undefined")], frames="frame-masks both methods scored",
        values=f"ratio of the mean {where or 'task '}RMSEs [paired 95 % percentile-bootstrap interval] "
               "(2,000 resamples, seed 0)",
    )
    if undefined:
        notes.append(f"¶ {'; '.join(dict.fromkeys(undefined))}.")
    return "\n".join(lines + [""] + notes + trained_note(learned_cells))


def every_method_vs_strongest(
    result: EvaluationResult, *, classical: Iterable[str] = CLASSICAL_METHODS, keys: Sequence[str] | None = None,
    confidence: float = 0.95, n_resamples: int = 2000, seed: int = 0,
) -> list[dict[str, Any]]:
    """Every method's RMSE of the task ÷ the strongest classical method's, per ``keys`` group (default: the
    input kind, when a row is of a scan, and the protocol; all drives pooled), paired as in :func:`learned_vs_classical`.

    Returns
    -------
    list of dict
        Per group and method: the ``keys``, ``task``, ``method``, ``kind``, ``rmse`` (its mean RMSE of the
        task on the frames it shares with the strongest classical one), ``classical``, ``ratio`` with
        ``ratio_low`` / ``ratio_high`` (NaN from one frame or a classical RMSE of 0) and ``ratio_n``, and
        ``ms_per_frame``.
    """
    keys = tuple(k for k in headline_keys(result) if k != "drive") if keys is None else tuple(keys)
    kinds = _kinds(result, frozenset(classical))
    out = []
    for group, by_method, task, values in _task_groups(result, keys):
        strong = [m for m, v in values.items() if v and kinds.get(m) == "classical"]
        if not strong:
            continue
        best = min(strong, key=lambda m: float(np.mean(list(values[m].values()))))
        for method, value in values.items():
            shared = sorted(set(value) & set(values[best]))
            if not shared:
                continue
            a = np.array([value[k] for k in shared])
            b = np.array([values[best][k] for k in shared])
            ratio = low = high = math.nan
            if b.mean() > 0:
                ratio, low, high = bootstrap_ratio_ci(a, b, confidence=confidence, n_resamples=n_resamples, seed=seed)
            ms = [r["ms"] for r in by_method[method] if np.isfinite(r.get("ms", math.nan))]
            out.append({**dict(zip(keys, group)), "task": task, "method": method, "kind": kinds.get(method),
                        "rmse": float(a.mean()), "classical": best, "ratio": float(ratio), "ratio_low": float(low),
                        "ratio_high": float(high), "ratio_n": len(shared),
                        "ms_per_frame": float(np.mean(ms)) if ms else math.nan})
    return out


def every_method_markdown(rows: list[dict[str, Any]]) -> str:
    """Markdown of :func:`every_method_vs_strongest` (empty string when there is nothing to compare)."""
    if not rows:
        return ""
    keys = [k for k in ("input_kind", "protocol") if k in rows[0]]
    lines = ["| " + " | ".join(keys + ["method", "frames", "RMSE of the task (m)", "÷ strongest classical [95 % CI]",
                                       "ms/frame"]) + " |",
             "|" + "|".join(["---"] * (len(keys) + 1) + ["---:"] * 4) + "|"]
    cells = []
    for r in rows:
        cells.append("–" if math.isnan(r["ratio"]) else interval_cell(
            r["ratio"], r["ratio_low"], r["ratio_high"], r["ratio_n"], ".3f", brackets=True) + f" ({r['classical']})")
        ms = "–" if math.isnan(r["ms_per_frame"]) else f"{r['ms_per_frame']:.0f}"
        lines.append("| " + " | ".join([str(r[k]) for k in keys] + [
            r["method"], str(r["ratio_n"]), f"{r['rmse']:.3f}", cells[-1], ms]) + " |")
    notes = table_notes(cells, frames="frame-masks the method and the strongest classical one both scored",
                        values="each method's mean RMSE of the task (the hole; under densify-v1 the ground-truth "
                               "pixels the scan did not measure) ÷ the strongest classical method's, with a paired "
                               "95 % percentile-bootstrap interval (2,000 resamples, seed 0)")
    return "\n".join(lines + [""] + notes)
