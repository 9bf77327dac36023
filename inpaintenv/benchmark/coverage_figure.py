"""``coverage_vs_nearest.png`` and ``coverage_vs_distance.png``: the conditional coverage of each
method's interval, by distance to the nearest measurement and by depth.

A 90 % interval may cover 90 % of the task's pixels pooled and still far less of the pixels far from
any measurement, or of the far ones; these figures show where. Each draws the share of the task's
pixels whose ground truth lies inside the method's interval, per bin of the distance (pixels) to the
nearest pixel the method's input measured (:data:`~inpaintenv.benchmark.figures.NEAREST_BINS`), or
per ground-truth depth bin (:data:`~inpaintenv.benchmark.figures.DISTANCE_BINS`), beside the nominal
coverage (dashed). Pixels pooled over the figure frames, the intervals those the rows scored
(:meth:`~inpaintenv.benchmark.figures.FramePredictions.bounds`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..report import style
from ..report.plots import Line, figure_png, line_figure
from .figure_io import save_png
from .figures import DISTANCE_BINS, NEAREST_BINS, FramePredictions, nearest_distance

__all__ = ["COVERAGE_FIGURES", "coverage_by_bin", "plot_coverage_by_bin"]

#: The two figures' file names: by distance to the nearest measurement, by ground-truth depth.
COVERAGE_FIGURES = ("coverage_vs_nearest.png", "coverage_vs_distance.png")


def coverage_by_bin(predictions: FramePredictions, name: str, indices: Sequence[int]) -> dict[str, list[float]]:
    """Method ``name``'s coverage per distance bin (``"nearest"``, :data:`NEAREST_BINS`, px) and per
    ground-truth depth bin (``"depth"``, :data:`DISTANCE_BINS`, m), the task's pixels pooled over
    ``indices``; NaN for an empty bin, and an empty dict when the method gives no interval."""
    edges = {"nearest": np.asarray(NEAREST_BINS, float), "depth": np.asarray(DISTANCE_BINS, float)}
    hits = {key: np.zeros(len(e) - 1) for key, e in edges.items()}
    pixels = {key: np.zeros(len(e) - 1) for key, e in edges.items()}
    for i in indices:
        bounds = predictions.bounds(name, int(i))
        if bounds is None:
            return {}
        gt, _ = predictions.frame(int(i))
        sel = predictions.scored(int(i))
        inside = (gt[sel] >= bounds[0][sel]) & (gt[sel] <= bounds[1][sel])
        for key, value in (("nearest", nearest_distance(predictions.measured(int(i)))[sel]), ("depth", gt[sel])):
            which = np.clip(np.digitize(value, edges[key][1:-1]), 0, len(edges[key]) - 2)
            pixels[key] += np.bincount(which, minlength=len(edges[key]) - 1)
            hits[key] += np.bincount(which, weights=inside, minlength=len(edges[key]) - 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return {key: (hits[key] / pixels[key]).tolist() for key in hits}


def plot_coverage_by_bin(
    predictions: FramePredictions, names: Sequence[str], indices: Sequence[int], folder: str | Path, *,
    coverage: float, title: str, colours: Mapping[str, Any] | None = None,
) -> tuple[list[Path], dict[str, dict[str, list[float]]]]:
    """Draw :func:`coverage_by_bin` of each of ``names`` that gives an interval into ``folder``'s
    :data:`COVERAGE_FIGURES`, beside the nominal ``coverage``; returns the paths and the values per method."""
    colours = colours or style.method_colours(names)
    values = {name: v for name in names if (v := coverage_by_bin(predictions, name, indices))}
    near, deep = np.asarray(NEAREST_BINS, float), np.asarray(DISTANCE_BINS, float)
    xs = {"nearest": np.sqrt(np.maximum(near[:-1], 0.5) * np.minimum(near[1:], 2 * np.maximum(near[:-1], 1))),
          "depth": 0.5 * (deep[:-1] + deep[1:])}
    paths = []
    for file, key, xlabel in zip(COVERAGE_FIGURES, ("nearest", "depth"),
                                 ("distance to the nearest measured pixel (px)", "ground-truth depth (m)")):
        lines = []
        for name, v in values.items():
            keep = np.isfinite(v[key])  # an empty bin draws no point
            lines.append(Line(name, list(xs[key][keep]), list(np.asarray(v[key])[keep]), colours.get(name, "black")))
        x = list(xs[key])
        lines.append(Line(f"nominal {coverage:g}", [x[0], x[-1]], [coverage, coverage], "grey", "--"))
        fig = line_figure(lines, title, xlabel, "coverage of the interval, pixels pooled", log_x=key == "nearest")
        paths.append(save_png(figure_png(fig), Path(folder) / file))
    return paths, values
