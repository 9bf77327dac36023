"""``report.html``: one page per run folder that opens offline, rebuilt from the folder alone.

The page holds the results table (each method's mean ± 95 % interval of the task's RMSE and
its ratio to the strongest classical method of the task; sortable by a click on any
header), per task the figures of the run folder (:func:`figure_groups`: the ones
:mod:`.figures` draws and any other PNG a run wrote under ``figures/``, grouped by the task
their ``figures.json`` names or their folder), a per-frame RMSE figure of every task drawn
here from the rows, and the run's provenance (command, versions, data, seeds, time taken).

Nothing is re-predicted: the page comes from the rows (``rows/*.jsonl``), ``run.json``,
the ``meta`` and ``environment`` of ``results.json`` when there is one, and the figure files.
Every figure is a PNG embedded as base64, and the only
script is the table's sorter, inline: the page loads nothing from the network.
"""

from __future__ import annotations

import base64
import html
import math
import os
import re
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..data.inputs import INPUTS
from ..exceptions import InpaintenvError
from ..files import read_bytes, read_json, write_text_atomic
from ..masks import get_protocol
from ..progress import count, format_duration
from ..report import style
from ..report.plots import box_figure, figure_png
from ..report.results import EvaluationResult
from ..report.tables import summary_table
from .headline import every_method_vs_strongest
from ..files.ownership import claim
from .rows import read_run_rows

__all__ = ["REPORT_FILE", "build_html", "figure_groups", "write_html_report"]

#: The page's file name in the run folder.
REPORT_FILE = "report.html"
#: Largest figure file embedded (bytes); a larger one is named, not embedded.
MAX_FIGURE_BYTES = 8 * 1024 * 1024

#: Captions of the figures :mod:`.figures` draws, in the order shown (any other PNG follows, by name).
KNOWN_FIGURES: tuple[tuple[str, str], ...] = (
    ("error_vs_hole_size.png", "Error by hole size: mean RMSE of the task against the occluded share of the "
                               "frame, every frame-mask of the task (from the rows)."),
    ("error_vs_distance.png", "Error by depth: RMSE of the task's pixels per ground-truth range bin, pixels "
                              "pooled over frames spread over the drives."),
    ("error_vs_nearest.png", "Error by distance to the nearest measurement: RMSE of the task's pixels against "
                             "their distance in pixels to the nearest pixel the method's input measured."),
    ("error_rejection.png", "Error rejection (methods with intervals): RMSE of the most confident pixels kept, "
                            "against the pixels nearest the hole border (dashed)."),
    ("error_vs_beams.png", "Error by LiDAR density: mean RMSE of the task against the beams of the LiDAR simulated "
                           "(every k-th ring of the 64-beam scan kept), one line per method (from the rows)."),
    ("coverage_vs_nearest.png", "Conditional coverage (methods with intervals): the share of the task's pixels "
                                "inside the interval against their distance to the nearest measurement, pixels pooled, "
                                "beside the nominal coverage (dashed)."),
    ("coverage_vs_distance.png", "Conditional coverage by depth: the share of the task's pixels inside the interval "
                                 "per ground-truth range bin, beside the nominal coverage (dashed)."),
    ("uncertainty.png", "Per-pixel intervals: the reliability diagram (coverage at nominal 50-95 %, per image "
                        "solid, pixels pooled dashed) and each method's per-image AUSE and AURG (RMSE-based)."),
)

_SCRIPT = """
document.querySelectorAll('table.sortable').forEach(function (table) {
  var heads = table.tHead.rows[0].cells;
  Array.prototype.forEach.call(heads, function (th, col) {
    th.addEventListener('click', function () {
      var asc = th.getAttribute('aria-sort') !== 'ascending';
      Array.prototype.forEach.call(heads, function (h) { h.removeAttribute('aria-sort'); });
      th.setAttribute('aria-sort', asc ? 'ascending' : 'descending');
      var body = table.tBodies[0];
      var rows = Array.prototype.slice.call(body.rows);
      rows.sort(function (a, b) {
        var x = a.cells[col].getAttribute('data-v'), y = b.cells[col].getAttribute('data-v');
        if (x === '' || y === '') { return (x === '') - (y === ''); }  /* empty cells last either way */
        var nx = Number(x), ny = Number(y);
        var c = (isNaN(nx) || isNaN(ny)) ? x.localeCompare(y) : nx - ny;
        return asc ? c : -c;
      });
      rows.forEach(function (r) { body.appendChild(r); });
    });
  });
});
"""

_STYLE = """
body { font: 14px/1.45 system-ui, sans-serif; margin: 1.5em auto; max-width: 1400px; padding: 0 1em; color: #222; }
h1 { font-size: 1.5em; } h2 { margin-top: 2em; border-bottom: 1px solid #ccc; } h3 { margin-top: 1.4em; }
table { border-collapse: collapse; font-size: 13px; }
th, td { padding: 3px 8px; border-bottom: 1px solid #e4e4e4; text-align: right; white-space: nowrap; }
th { background: #f3f3f3; cursor: pointer; user-select: none; position: sticky; top: 0; }
th[aria-sort=ascending]::after { content: " \\25B2"; } th[aria-sort=descending]::after { content: " \\25BC"; }
td.t, th.t { text-align: left; }
tr.classical-best td { font-weight: 600; }
figure { display: inline-block; margin: 0 1em 1em 0; vertical-align: top; max-width: 100%; }
figure img { max-width: 100%; border: 1px solid #ddd; }
figure.plot img { width: 560px; }
figcaption { font-size: 12px; color: #555; max-width: 560px; }
figure.frame figcaption { max-width: none; }
dl { display: grid; grid-template-columns: max-content auto; gap: 2px 1em; } dt { font-weight: 600; }
dd { margin: 0; font-family: ui-monospace, monospace; font-size: 12px; word-break: break-all; }
.note { color: #555; font-size: 12px; }
"""


# -- reading the run folder ----------------------------------------------------------------

def _optional_json(path: Path, what: str) -> dict[str, Any]:
    """A JSON object of the run folder, or {} when it is missing or cannot be read (the page says less)."""
    if not os.path.lexists(path):
        return {}
    try:
        doc = read_json(path, what, follow_links=False)
    except (InpaintenvError, OSError):
        return {}
    return doc if isinstance(doc, dict) else {}


def _run_rows(run_dir: Path) -> list[dict[str, Any]]:
    """Every row of ``rows/*.jsonl``, each one its run could have written (:func:`.rows.read_run_rows`)."""
    return read_run_rows(run_dir / "rows", _optional_json(run_dir / "run.json", "run file"))


def _labels(meta: dict[str, Any]) -> dict[str, Any]:
    """What the tables take of ``results.json``'s meta, where it has the form a run writes: each method's
    kind (a string) and the drives it was trained on (a list of strings); a hand-edited entry is left out."""
    kinds, trained = meta.get("kinds"), meta.get("training_drives")
    return {"kinds": {m: k for m, k in kinds.items() if isinstance(k, str)} if isinstance(kinds, dict) else {},
            "training_drives": {m: d for m, d in trained.items() if isinstance(d, list) and all(
                isinstance(x, str) for x in d)} if isinstance(trained, dict) else {}}


def _method_order(rows: list[dict[str, Any]], meta: dict[str, Any], run: dict[str, Any]) -> list[str]:
    """The run's order of methods: as results.json or run.json recorded them, then any other in row order."""
    recorded = [*(meta.get("kinds") or {}), *(run.get("methods") or {})]
    return list(dict.fromkeys([m for m in recorded if isinstance(m, str)] + [r["method"] for r in rows]))


def _tasks(rows: list[dict[str, Any]]) -> list[tuple[str, str]]:
    """``(input kind, protocol)`` of every task, maps first, in the order the rows hold them."""
    seen = list(dict.fromkeys((r.get("input_kind", "map"), r["protocol"]) for r in rows))
    return sorted(seen, key=lambda t: t[0] != "map")


def task_label(kind: str, protocol: str) -> str:
    """A task in text as the run names it: ``rect-v1`` on maps, ``scan:rect-v1`` on scans."""
    return protocol if kind == "map" else f"{kind}:{protocol}"


def _task_title(kind: str, protocol: str) -> str:
    try:
        unmeasured = get_protocol(protocol).task == "unmeasured"
    except InpaintenvError:
        unmeasured = False
    spec = INPUTS.get(kind)
    what = ("Densifying single scans" if unmeasured else "Holes in single scans") if spec and spec.separate else (
        "Holes in maps" if kind == "map" else f"Input {kind}")
    if spec is not None and spec.thinned:
        what += f" ({spec.density})"
    return f"{what} — {task_label(kind, protocol)}"


def _metric(protocol: str) -> str:
    """The task's RMSE column: ``hole_rmse``, or ``unmeasured_rmse`` under a protocol without holes."""
    try:
        return f"{get_protocol(protocol).task}_rmse"
    except InpaintenvError:
        return "hole_rmse"


# -- figures -------------------------------------------------------------------------------

def _slug(label: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", label)


def figure_groups(run_dir: str | os.PathLike, tasks: Sequence[str]) -> dict[str, list[Path]]:
    """Every PNG under the run folder's ``figures/`` (and its folders one level down), by task label.

    A folder's task is the ``task`` its ``figures.json`` records, else the task whose name the
    folder has (:func:`~inpaintenv.benchmark.figures.task_folder`), else ``figures/`` is the
    first of ``tasks`` and another folder its own name. Figures other helpers or later versions
    draw there are picked up the same way. Within a task: the known figures first, then others
    by name, frame panels last.
    """
    base = Path(run_dir) / "figures"
    groups: dict[str, list[Path]] = {}
    if not base.is_dir() or base.is_symlink():
        return groups
    folders = [base] + sorted(p for p in base.iterdir() if p.is_dir() and not p.is_symlink())
    by_slug = {_slug(t): t for t in tasks}
    known = [name for name, _ in KNOWN_FIGURES]
    for folder in folders:
        stamp = _optional_json(folder / "figures.json", "figure stamp")
        task = stamp.get("task") if isinstance(stamp.get("task"), str) else None
        if task is None:
            task = (tasks[0] if tasks else "run") if folder == base else by_slug.get(folder.name, folder.name)
        pngs = [p for p in folder.glob("*.png") if p.is_file() and not p.is_symlink() and not p.name.startswith(".")]
        pngs.sort(key=lambda p: (p.name.startswith("frame_"), known.index(p.name) if p.name in known else len(known),
                                 p.name))
        if pngs:
            groups.setdefault(task, []).extend(pngs)
    return groups


def _caption(path: Path) -> str:
    for name, caption in KNOWN_FIGURES:
        if path.name == name:
            return caption
    if path.name.startswith("frame_"):
        return (f"Frame {path.stem[6:]}: per method the input, the ground truth, the fill and its absolute error on "
                "the task's pixels; depth and error each on one scale in metres (colour bars below); grey = no data.")
    return path.stem.replace("_", " ").capitalize() + "."


def _img(data: bytes, alt: str) -> str:
    return f'<img alt="{html.escape(alt)}" src="data:image/png;base64,{base64.b64encode(data).decode("ascii")}">'


def _figure_file(path: Path, run_dir: Path) -> str:
    rel = path.relative_to(run_dir).as_posix()
    cls = "frame" if path.name.startswith("frame_") else "plot"
    try:
        data = read_bytes(path, "figure", limit=MAX_FIGURE_BYTES, follow_links=False)
    except (InpaintenvError, OSError) as exc:
        return f'<p class="note">{html.escape(rel)} not embedded: {html.escape(str(exc))}</p>'
    if not data.startswith(b"\x89PNG\r\n\x1a\n"):
        return f'<p class="note">{html.escape(rel)} not embedded: not a PNG file</p>'
    return (f'<figure class="{cls}">{_img(data, rel)}<figcaption>{html.escape(_caption(path))} '
            f'<span class="note">({html.escape(rel)})</span></figcaption></figure>')


def _per_frame_figure(rows: list[dict[str, Any]], methods: list[str], metric: str) -> bytes | None:
    """A box per method of its per-frame RMSE of the task, from the rows (PNG bytes,
    :func:`inpaintenv.report.plots.box_figure`)."""
    values = {m: [r[metric] for r in rows if r["method"] == m and _finite(r.get(metric))] for m in methods}
    values = {m: v for m, v in values.items() if v}
    if not values:
        return None
    order = sorted(values, key=lambda m: float(np.mean(values[m])))
    n = len({(r["seed"], r["index"]) for r in rows})
    return figure_png(box_figure({m: values[m] for m in order}, style.method_colours(methods),
                                 f"every frame-mask of the task ({n}), from the rows; best mean at the top",
                                 f"{metric.replace('_rmse', '')} RMSE per frame (m)"))


# -- the table -----------------------------------------------------------------------------

def _finite(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _num(v: Any, fmt: str) -> tuple[str, str]:
    """(text, sort key) of a number; a dash and an empty key when it is missing."""
    return (format(v, fmt), repr(float(v))) if _finite(v) else ("–", "")


def _cell(text: str, key: str, cls: str = "") -> str:
    return f'<td{f" class={cls!r}" if cls else ""} data-v="{html.escape(key)}">{html.escape(text)}</td>'


def _mean_ci(entry: dict[str, Any], metric: str, fmt: str) -> tuple[str, str]:
    mean, low, high = entry.get(metric), entry.get(f"{metric}_low"), entry.get(f"{metric}_high")
    text, key = _num(mean, fmt)
    if key and _finite(low) and _finite(high):
        text += f" ± {format((high - low) / 2, fmt)}"
    return text, key


def _results_table(result: EvaluationResult, tasks: list[tuple[str, str]]) -> str:
    keys = ("method", "input_kind", "protocol")
    table = summary_table(result, keys)
    ratios = {(e.get("input_kind", "map"), e["protocol"], e["method"]): e for e in every_method_vs_strongest(
        result, keys=("input_kind", "protocol"))}
    kinds = result.meta.get("kinds") or {}
    intervals = any("hole_coverage" in r for r in result.rows)
    head = ["method", "kind", "task", "frames", "task RMSE (m)", "task MAE (m)", "all RMSE (m)",
            "÷ strongest classical [95 % CI]", "strongest classical", "ms/frame"]
    if intervals:
        head += ["hole coverage", "interval width (m)"]
    lines = ['<table class="sortable" id="results-table"><thead><tr>'
             + "".join(f'<th class="{"t" if k < 3 or h == "strongest classical" else ""}" title="sort">'
                       f"{html.escape(h)}</th>" for k, h in enumerate(head)) + "</tr></thead><tbody>"]
    order = {t: k for k, t in enumerate(tasks)}
    table.sort(key=lambda e: (order.get((e["input_kind"], e["protocol"]), 99),
                              e.get(_metric(e["protocol"])) if _finite(e.get(_metric(e["protocol"]))) else math.inf))
    for e in table:
        metric = _metric(e["protocol"])
        r = ratios.get((e["input_kind"], e["protocol"], e["method"]), {})
        kind = kinds.get(e["method"]) or r.get("kind") or ""
        ratio, key = _num(r.get("ratio"), ".3f")
        if key and _finite(r.get("ratio_low")) and _finite(r.get("ratio_high")):
            ratio += f" [{r['ratio_low']:.3f}, {r['ratio_high']:.3f}]"
        label = task_label(e["input_kind"], e["protocol"])
        best = r.get("classical") == e["method"]
        cells = [
            _cell(e["method"], e["method"], "t"), _cell(str(kind), str(kind), "t"), _cell(label, label, "t"),
            _cell(str(e.get("n_frames", "")), str(e.get("n_frames", ""))),
            _cell(*_mean_ci(e, metric, ".3f")), _cell(*_mean_ci(e, metric.replace("rmse", "mae"), ".3f")),
            _cell(*_mean_ci(e, "all_rmse", ".3f")), _cell(ratio, key),
            _cell(r.get("classical", ""), r.get("classical", ""), "t"), _cell(*_num(e.get("ms_per_frame"), ".1f")),
        ]
        if intervals:
            cells += [_cell(*_mean_ci(e, "hole_coverage", ".3f")), _cell(*_mean_ci(e, "hole_interval_width", ".2f"))]
        lines.append(f'<tr{" class=classical-best" if best else ""}>' + "".join(cells) + "</tr>")
    lines.append("</tbody></table>")
    lines.append(
        '<p class="note">Click a header to sort. Task RMSE: in the hole, or under densify-v1 on the ground-truth '
        "pixels the scan did not measure; mean over frames ± half-width of the 95 % percentile-bootstrap interval "
        "(2,000 resamples, seed 0; none from one frame). ÷ strongest classical: the method's mean task RMSE over the "
        "strongest classical method's on the frames both scored, with a paired bootstrap interval; that method's "
        "row is bold.</p>")
    return "\n".join(lines)


# -- provenance ----------------------------------------------------------------------------

def _provenance(run_dir: Path, meta: dict[str, Any], environment: dict[str, Any], run: dict[str, Any],
                rows: list[dict[str, Any]]) -> str:
    versions = environment.get("versions") or {}
    ms = [r["ms"] for r in rows if _finite(r.get("ms"))]
    fig_seconds = [s for p in [run_dir / "figures", *(run_dir / "figures").glob("*/")]
                   if _finite(s := _optional_json(p / "figures.json", "figure stamp").get("seconds"))]
    items: list[tuple[str, str]] = [
        ("command", str(meta.get("command", "not recorded (no results.json)"))),
        ("data", str(meta.get("source") or run.get("source") or "not recorded")),
        ("tasks", ", ".join(task_label(k, p) for k, p in _tasks(rows))),
        ("seeds", ", ".join(str(s) for s in sorted({r["seed"] for r in rows}))),
        ("frames", f"{len({(r.get('input_kind', 'map'), r['index']) for r in rows})} (input kind, frame) pairs; "
                   f"drives: {', '.join(sorted({str(r.get('drive')) for r in rows}))}"),
    ]
    if "holdout" in meta:
        items.append(("held-out share of drives", str(meta["holdout"])))
    if meta.get("interval_coverage") is not None:
        items.append(("interval coverage", str(meta["interval_coverage"])))
    if run.get("data"):
        items.append(("data fingerprint", ", ".join(f"{k}: {v}" for k, v in run["data"].items())))
    items += [
        ("methods' own time", f"{format_duration(sum(ms) / 1000.0)} summed over {len(ms)} frame scores (rows' ms)"),
    ]
    if _finite(meta.get("seconds_scoring")):
        items.append(("this command's scoring", format_duration(meta["seconds_scoring"])
                      + " (building the methods, scoring what was left, in the last run of the command)"))
    if fig_seconds:
        items.append(("figures", f"{format_duration(sum(fig_seconds))} drawing them (the last time each was drawn)"))
    if versions:
        items.append(("versions", ", ".join(f"{k} {v}" for k, v in versions.items() if v)))
    for key in ("python", "platform", "cpu_model", "cpu_count", "torch_threads"):
        if key in environment:
            items.append((key.replace("_", " "), str(environment[key])))
    identities = run.get("methods") or {}
    body = "".join(f"<dt>{html.escape(k)}</dt><dd>{html.escape(v)}</dd>" for k, v in items)
    methods = "".join(f"<dt>{html.escape(str(k))}</dt><dd>{html.escape(str(v))}</dd>" for k, v in identities.items())
    return (f"<dl>{body}</dl><h3>What each method is (run.json)</h3><dl>{methods}</dl>"
            f'<p class="note">Colour maps: depth in {style.DEPTH_CMAP} (perceptually uniform: equal steps in metres '
            f"look like equal steps in colour, and it stays ordered in grey scale and for colour-blind readers), "
            f"absolute error in {style.ERROR_CMAP} (black = exact); grey = no data.</p>")


# -- the page ------------------------------------------------------------------------------

def build_html(run_dir: str | os.PathLike) -> str:
    """The report page of the run folder ``run_dir``, from its rows, records and figure files.

    Raises
    ------
    InvalidInputError
        When the folder holds no row of a run.
    RunStateError
        A row file that is not one (as a resume refuses it).
    """
    from ..exceptions import InvalidInputError

    run_dir = Path(run_dir)
    rows = _run_rows(run_dir)
    if not rows:
        raise InvalidInputError(f"{run_dir} holds no rows of a benchmark run (rows/*.jsonl); nothing to report")
    results = _optional_json(run_dir / "results.json", "results")
    meta = results.get("meta") if isinstance(results.get("meta"), dict) else {}
    environment = results.get("environment") if isinstance(results.get("environment"), dict) else {}
    run = _optional_json(run_dir / "run.json", "run file")
    methods = _method_order(rows, meta, run)
    rows.sort(key=lambda r: (methods.index(r["method"]), r.get("input_kind", "map"), r["protocol"], r["seed"],
                             r["index"]))
    result = EvaluationResult(rows=rows, meta=_labels(meta))
    tasks = _tasks(rows)
    labels = [task_label(k, p) for k, p in tasks]
    groups = figure_groups(run_dir, labels)

    parts = [f"<h2 id='results'>Results</h2>{_results_table(result, tasks)}"]
    for (kind, protocol), label in zip(tasks, labels):
        task_rows = [r for r in rows if r.get("input_kind", "map") == kind and r["protocol"] == protocol]
        parts.append(f"<h2 id='task-{_slug(label)}'>{html.escape(_task_title(kind, protocol))}</h2>")
        parts.append("<h3>Which is better, where</h3>")
        per_frame = _per_frame_figure(task_rows, methods, _metric(protocol))
        if per_frame is not None:
            parts.append(f'<figure class="plot">{_img(per_frame, "per-frame RMSE of " + label)}<figcaption>'
                         "RMSE of the task per frame, one box per method (from the rows).</figcaption></figure>")
        files = groups.pop(label, [])
        plots = [p for p in files if not p.name.startswith("frame_")]
        frames = [p for p in files if p.name.startswith("frame_")]
        parts += [_figure_file(p, run_dir) for p in plots]
        if frames:
            parts.append("<h3>Frames</h3>")
            parts += [_figure_file(p, run_dir) for p in frames]
        elif not plots:
            parts.append('<p class="note">No figure files for this task (run with --figure-frames N, N &gt; 0, to '
                         "draw frames and the error by depth and by distance).</p>")
    for label, files in groups.items():  # figures of a folder no task of the rows names
        parts.append(f"<h2>{html.escape(label)}</h2>")
        parts += [_figure_file(p, run_dir) for p in files]
    parts.append(f"<h2 id='provenance'>Provenance</h2>{_provenance(run_dir, meta, environment, run, rows)}")

    nav = " · ".join([f"<a href='#results'>results</a>"]
                     + [f"<a href='#task-{_slug(lb)}'>{html.escape(lb)}</a>" for lb in labels]
                     + ["<a href='#provenance'>provenance</a>"])
    seeds = sorted({r["seed"] for r in rows})
    summary = (f"{count(len(methods), 'method')}, {count(len(tasks), 'task')}, "
               f"{count(len({r['index'] for r in rows}), 'frame')}, seed{'s' * (len(seeds) != 1)} "
               f"{', '.join(map(str, seeds))}; the data and how the run was made are under provenance.")
    page = (
        "<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'>"
        "<meta name='viewport' content='width=device-width, initial-scale=1'>"
        f"<title>inpaintenv benchmark report</title><style>{_STYLE}</style></head><body>"
        f"<h1>Benchmark report</h1><p>{html.escape(summary)}</p><p>{nav}</p>"
        + "\n".join(parts)
        + f"<script>{_SCRIPT}</script></body></html>\n"
    )
    # A path or command that is not UTF-8 (surrogate escapes) is shown escaped: the page is UTF-8.
    return page.encode("utf-8", "backslashreplace").decode("utf-8")


def write_html_report(run_dir: str | os.PathLike, log: Callable[[str], None] | None = None) -> Path | None:
    """Write ``report.html`` into the run folder ``run_dir`` (replacing the one a run wrote there before).

    The file is recorded as the run's (:mod:`inpaintenv.files.ownership`) and written whole or not at all.

    Returns
    -------
    Path or None
        The page's path; None (and a line in ``log``) when no frame was scored (every
        frame skipped): there is nothing to report.
    """
    run_dir = Path(run_dir)
    start = time.monotonic()
    if not _run_rows(run_dir):
        if log is not None:
            log(f"no frame was scored: no {REPORT_FILE}")
        return None
    page = build_html(run_dir)
    path = run_dir / REPORT_FILE
    claim(run_dir, REPORT_FILE)
    write_text_atomic(path, page)
    if log is not None:
        log(f"wrote {path} ({len(page.encode()) / 1e6:.1f} MB in {format_duration(time.monotonic() - start)})")
    return path
