"""The LiDAR density axis of a run: each method's error at every scan density it was scored on.

A run that scores the scan and its density variants (``--input scan --input scan-rings16-v1
...``, :mod:`inpaintenv.data.inputs`) gets a table of the task's RMSE per method, protocol
and density (``results.md``, ``results.json``'s ``by_density``) and ``error_vs_beams.png``:
RMSE against the beams of the LiDAR simulated (64, 32, 16, 8), one line per method. The
task's RMSE is the hole RMSE, under a protocol of task ``unmeasured`` (``densify-v1``) the
RMSE on the ground-truth pixels the input did not measure. From the rows alone.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping

import numpy as np

from ..data.inputs import INPUT_KINDS, INPUTS
from ..exceptions import InpaintenvError
from ..masks import get_protocol
from ..report import style
from ..report.results import EvaluationResult

__all__ = ["density_markdown", "density_table", "has_beams_axis", "has_density_axis", "plot_error_vs_beams",
           "write_density_figure"]


def _task_metric(protocol: str) -> str:
    try:
        return "unmeasured_rmse" if get_protocol(protocol).task == "unmeasured" else "hole_rmse"
    except InpaintenvError:  # a row of a protocol this version lacks: its hole
        return "hole_rmse"


def _scan_kinds(result: EvaluationResult) -> list[str]:
    """The scan input kinds of the run's rows, in :data:`INPUT_KINDS` order."""
    kinds = {r.get("input_kind", "map") for r in result.rows}
    return [k for k in INPUT_KINDS if k in kinds and INPUTS[k].separate]


def has_density_axis(result: EvaluationResult) -> bool:
    """Whether the run scored scans at more than one density."""
    return len(_scan_kinds(result)) > 1


def has_beams_axis(result: EvaluationResult) -> bool:
    """Whether the run scored scans at more than one number of beams (``error_vs_beams.png`` is drawn)."""
    return len({INPUTS[k].beams for k in _scan_kinds(result) if INPUTS[k].keep_fraction == 1.0}) > 1


def density_table(result: EvaluationResult) -> list[dict[str, Any]]:
    """One entry per method, protocol and scan input kind: the mean of the task's RMSE over its frames.

    Returns
    -------
    list of dict
        ``method``, ``protocol``, ``input_kind``, ``density`` (in words), ``beams``,
        ``keep_fraction``, ``metric`` (the row column averaged), ``rmse`` (m, None
        without a finite value) and ``n`` (frames in the mean); empty unless
        :func:`has_density_axis`.
    """
    if not has_density_axis(result):
        return []
    groups: dict[tuple[str, str, str], list[float]] = {}
    for r in result.rows:
        kind = r.get("input_kind", "map")
        if kind not in INPUTS or not INPUTS[kind].separate:
            continue
        value = r.get(_task_metric(r["protocol"]))
        values = groups.setdefault((r["method"], r["protocol"], kind), [])
        if isinstance(value, (int, float)) and np.isfinite(value):
            values.append(float(value))
    order = {k: i for i, k in enumerate(INPUT_KINDS)}
    out = []
    for (method, protocol, kind), values in sorted(groups.items(), key=lambda g: (g[0][0], g[0][1], order[g[0][2]])):
        spec = INPUTS[kind]
        out.append({"method": method, "protocol": protocol, "input_kind": kind, "density": spec.density,
                    "beams": spec.beams, "keep_fraction": spec.keep_fraction, "metric": _task_metric(protocol),
                    "rmse": float(np.mean(values)) if values else None, "n": len(values)})
    return out


def density_markdown(table: list[dict[str, Any]]) -> str:
    """The :func:`density_table` as Markdown: a row per method and protocol, a column per density (RMSE in m)."""
    kinds = [k for k in INPUT_KINDS if any(e["input_kind"] == k for e in table)]
    cells: dict[tuple[str, str], dict[str, str]] = {}
    for e in table:
        text = "–" if e["rmse"] is None else f"{e['rmse']:.2f}"
        cells.setdefault((e["method"], e["protocol"]), {})[e["input_kind"]] = text
    head = ["method", "protocol", *(INPUTS[k].density + (f" ({k})" if k != "scan" else " (scan)") for k in kinds)]
    lines = ["| " + " | ".join(head) + " |", "|---|---|" + "---:|" * len(kinds)]
    for (method, protocol), row in cells.items():
        lines.append("| " + " | ".join([method, protocol, *(row.get(k, "") for k in kinds)]) + " |")
    return "\n".join(lines)


def plot_error_vs_beams(
    result: EvaluationResult, path: str | Path, *, colours: Mapping[str, Any] | None = None
) -> Path:
    """The task's RMSE (mean over frames) against the LiDAR's beams, one line per method (a protocol other than
    the first dashed), from the rows of the scan and its ring variants."""
    from .figures import _pyplot, _save  # noqa: PLC0415 - matplotlib only when a figure is drawn

    plt = _pyplot()
    colours = colours or style.method_colours(result.methods)
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    table = [e for e in density_table(result) if e["keep_fraction"] == 1.0 and e["rmse"] is not None]
    protocols = list(dict.fromkeys(e["protocol"] for e in table))
    for method in dict.fromkeys(e["method"] for e in table):
        for protocol in protocols:
            points = sorted((e["beams"], e["rmse"]) for e in table if e["method"] == method and e["protocol"] == protocol)
            if not points:
                continue
            label = method if len(protocols) == 1 else f"{method} ({protocol})"
            ax.plot([b for b, _ in points], [v for _, v in points], marker="o", label=label, color=colours.get(method),
                    linestyle=("-", "--", ":", "-.")[protocols.index(protocol) % 4])
    beams = sorted({e["beams"] for e in table})
    ax.set_xscale("log", base=2)
    ax.set_xticks(beams, [str(b) for b in beams])
    ax.minorticks_off()
    ax.set_xlabel("LiDAR beams (every k-th ring of the 64-beam scan kept)")
    ax.set_ylabel("RMSE of the task's pixels (m), mean over frames")
    ax.set_title("hole RMSE; under densify-v1 the RMSE where the input measured nothing", fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2 if len(table) > 16 else 1)
    fig.tight_layout()
    return _save(fig, path, dpi=100)


def write_density_figure(result: EvaluationResult, out_dir: str | Path) -> Path | None:
    """Draw ``error_vs_beams.png`` into ``out_dir`` (a run's ``figures/``) when the run has a beams axis.

    Written only over a file a run recorded (:mod:`inpaintenv.files.ownership`), whole or not at all.

    Returns
    -------
    Path or None
        The figure, or None when the run scored scans at one number of beams only.
    """
    from ..files import ownership  # noqa: PLC0415

    if not has_beams_axis(result):
        return None
    out = Path(out_dir)
    root = ownership.run_root(out)
    ownership.adopt(root)  # a folder holding files no run wrote is refused before anything is drawn
    out.mkdir(parents=True, exist_ok=True)
    path = out / "error_vs_beams.png"
    ownership.claim(root, path.resolve().relative_to(root.resolve()))
    return plot_error_vs_beams(result, path)
