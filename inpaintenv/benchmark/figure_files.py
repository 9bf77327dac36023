"""A task's figure files in a run folder: which figures, in which folder, drawn only when the rows changed.

:func:`write_figures` draws one task's figures (:mod:`.figures`) into its folder
(:func:`task_folder`), records them as the run's (:mod:`inpaintenv.files.ownership`) and stamps what they
show in ``figures.json``, so a rerun with nothing new draws nothing.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import time
from collections.abc import Callable, Collection, Mapping, Sequence
from pathlib import Path
from typing import Any

import inpaintenv

from ..data.base import DepthDataset
from ..data.inputs import INPUTS
from ..exceptions import FileTooLargeError, JSONFileError
from ..files import read_json, write_text_atomic
from ..masks import get_protocol
from ..metrics import as_coverage
from ..progress import count
from ..report import style
from ..report.results import EvaluationResult
from ..files import ownership
from .figures import (
    DISTANCE_FRAMES, FramePredictions, _describe, has_intervals, plot_error_rejection,
    plot_error_vs_distance, plot_error_vs_hole_size, plot_error_vs_nearest, spread_indices,
)
from .panels import frame_panel
from .coverage_figure import COVERAGE_FIGURES, plot_coverage_by_bin
from .uncertainty_figure import has_reliability, plot_uncertainty

__all__ = ["task_folder", "write_figures"]


def _stamp_of(path: Path) -> str | None:
    """The stamp ``figures.json`` records, or None when it is missing or unreadable (the figures are redrawn).

    A link, FIFO or device at ``figures.json`` is refused, never read or waited on.
    """
    if not os.path.lexists(path):
        return None
    try:
        doc = read_json(path, "figure stamp", follow_links=False)
    except (JSONFileError, FileTooLargeError):
        return None  # unreadable stamp: redraw
    return doc.get("stamp") if isinstance(doc, dict) else None


def task_folder(run_dir: str | Path, task: str, first: bool) -> Path:
    """The folder of a task's figures in a run folder: ``figures/`` for the run's first task,
    ``figures/<task>/`` for each other (``scan:rect-v1`` -> ``figures/scan_rect-v1/``)."""
    base = Path(run_dir) / "figures"
    return base if first else base / re.sub(r"[^A-Za-z0-9_.-]+", "_", task)


def _stamp(result: EvaluationResult, settings: dict[str, Any]) -> str:
    """Digest of what the figures show: every row's identity and hole RMSE, and the settings."""
    digest = hashlib.sha1(json.dumps(settings, sort_keys=True).encode())
    for r in result.rows:
        digest.update(f"{r['method']}|{r['protocol']}|{r['seed']}|{r['index']}|{r['hole_rmse']!r}\n".encode())
        if "rmse_keep_80" in r:  # only rows with intervals: other runs keep the stamp they had
            digest.update(f"{r['rmse_keep_80']!r}\n".encode())
    return digest.hexdigest()


class _Built(Mapping[str, Any]):
    """The drawn methods by name, each built from its factory only when a figure runs it again."""

    def __init__(self, factories: Mapping[str, Callable[[], Any]], names: Sequence[str]) -> None:
        self._factories, self._names, self._built = factories, list(names), {}

    def __getitem__(self, name: str) -> Any:
        if name not in self._names:
            raise KeyError(name)
        if name not in self._built:
            self._built[name] = self._factories[name]()
        return self._built[name]

    def __iter__(self) -> Any:
        return iter(self._names)

    def __len__(self) -> int:
        return len(self._names)


def write_figures(
    result: EvaluationResult,
    methods: Mapping[str, Callable[[], Any]],
    dataset: DepthDataset,
    out_dir: str | Path,
    *,
    panel_methods: Sequence[str],
    n_panels: int,
    protocol: str,
    seed: int,
    log: Callable[[str], None] = lambda msg: None,
    exclude: Collection[int] = (),
    unfilled: Mapping[str, str] | None = None,
    kept: Callable[[str, int], Any] | None = None,
) -> list[Path]:
    """Write a run's figures into ``out_dir``; skip them when they already show these rows.

    Parameters
    ----------
    result : EvaluationResult
        The task's rows (``error_vs_hole_size.png``, not drawn under a protocol without holes, and, when
        rows carry intervals, ``error_rejection.png`` come from them).
    methods : mapping of str to zero-argument callable
        Name -> a function returning the built method (built only if a figure needs it).
    dataset : DepthDataset
        The task's frames (its ``input_kind`` says whether a method is given maps or scans).
    out_dir : path
        Folder of the figures (:func:`task_folder`); ``figures.json`` there records what they show.
    panel_methods : sequence of str
        Methods drawn in the frame panels, ``error_vs_distance.png`` (by depth) and ``error_vs_nearest.png``.
    n_panels : int
        Frame panels to draw (the first of the :data:`DISTANCE_FRAMES` spread frames).
    protocol, seed
        Masks of the panels and ``error_vs_distance.png``.
    log : callable
        Receives one line before any method is run again (what, why, how long).
    exclude : collection of int
        Frames never drawn (the unreadable frames a run skipped).
    unfilled : mapping of str to str, optional
        Each method's ``unfilled`` policy in the run (``meta["unfilled"]`` of the runner's result).
    kept : callable, optional
        ``(name, index) -> prediction or None``: the run's own predictions of the figure frames
        (:meth:`~inpaintenv.benchmark.kept_frames.KeptFrames.lookup`); only the others are predicted again.
    """
    out = Path(out_dir)
    colours = style.method_colours(result.methods)  # one colour per method, in run order
    indices = spread_indices(dataset, max(n_panels, DISTANCE_FRAMES), exclude)
    panels = indices[:n_panels]
    kind = getattr(dataset, "input_kind", "map")
    task = INPUTS[kind].label(protocol)
    by_size = get_protocol(protocol).task == "hole"  # densify-v1 cuts no hole: no hole size to plot
    names = [out / f"frame_{i:04d}.png" for i in panels]
    names += [out / "error_vs_hole_size.png"] if by_size else []
    names += [out / "error_vs_distance.png", out / "error_vs_nearest.png"]
    coverage = result.meta.get("interval_coverage")
    if has_intervals(result):
        names.append(out / "error_rejection.png")
        names += [out / name for name in COVERAGE_FIGURES] if coverage else []
    if has_reliability(result):
        names.append(out / "uncertainty.png")
    settings = {"task": task, "coverage": result.meta.get("interval_coverage"), "panel_methods": list(panel_methods), "panels": panels, "distance": indices,
                "protocol": protocol, "seed": seed, "version": inpaintenv.__version__,
                "style": [style.DEPTH_CMAP, style.ERROR_CMAP, style.ERROR_PERCENTILE, list(style.METHOD_PALETTE)]}
    stamp_path = out / "figures.json"
    stamp = _stamp(result, settings)
    if _stamp_of(stamp_path) == stamp and all(p.exists() for p in names):
        log(f"figures in {out} already show these rows; not redrawn")
        return names
    root = ownership.run_root(out)
    ownership.adopt(root)  # a folder holding files no run wrote is refused before anything is drawn
    out.mkdir(parents=True, exist_ok=True)
    ownership.claim(root, *(p.resolve().relative_to(root.resolve()) for p in [*names, stamp_path]))
    for stale in sorted(set(out.glob("frame_*.png")) - set(names)):  # panels of other frames, drawn before
        ownership.remove(root, stale.resolve().relative_to(root.resolve()))  # only those a run recorded
    started = time.monotonic()
    if by_size:
        plot_error_vs_hole_size(result, out / "error_vs_hole_size.png", colours=colours)
    if has_intervals(result):
        plot_error_rejection(result, out / "error_rejection.png", colours=colours)
    if has_reliability(result):
        plot_uncertainty(result, out / "uncertainty.png", colours=colours)
    built = _Built(methods, panel_methods)
    predictions = FramePredictions(built, dataset, protocol, seed, unfilled,
                                   as_coverage(coverage) if has_intervals(result) and coverage else None, kept=kept)
    again = {n: [i for i in indices if predictions.held(n, i) is None] for n in panel_methods}
    again = {n: frames for n, frames in again.items() if frames}
    if again:
        ms = {e["method"]: e["ms_per_frame"] for e in result.group_table(("method",))}
        seconds = sum(ms.get(n, 0.0) * len(frames) for n, frames in again.items()) / 1000.0
        log(
            f"figures ({task}): running {count(len(again), 'method')} again on "
            f"{_describe(dataset, sorted({i for f in again.values() for i in f}))} (about {seconds:.0f} s): the frame "
            "panels and the error by depth and by distance to the nearest measurement need pixels, which the rows "
            "do not keep" + ("; error_vs_hole_size comes from the rows" if by_size else "")
        )
    else:
        log(f"figures ({task}): the pixels of {count(len(panel_methods), 'method')} on {_describe(dataset, indices)} "
            "kept from the run's own predictions; no method runs again")
    for i in panels:
        frame_panel(built, dataset, i, out / f"frame_{i:04d}.png", protocol=protocol, seed=seed,
                    colours=colours, predictions=predictions)
    plot_error_vs_distance(built, dataset, indices, out / "error_vs_distance.png", protocol=protocol, seed=seed,
                           colours=colours, predictions=predictions)
    plot_error_vs_nearest(built, dataset, indices, out / "error_vs_nearest.png", protocol=protocol, seed=seed,
                          colours=colours, predictions=predictions)
    if has_intervals(result) and coverage:
        plot_coverage_by_bin(predictions, list(panel_methods), indices, out, coverage=as_coverage(coverage),
                             colours=colours, title=f"{_describe(dataset, indices)}, {task}, seed {seed}")
    # The time taken is recorded beside the stamp, not in it: a redraw is decided by what the figures show.
    write_text_atomic(stamp_path, json.dumps({"stamp": stamp, **settings, "seconds": time.monotonic() - started},
                                             indent=1))
    return names
