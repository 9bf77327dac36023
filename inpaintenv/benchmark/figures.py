"""Figures of a benchmark task: error by hole size, by depth and by distance to the nearest measurement,
and the pixels every figure of a frame draws (:class:`FramePredictions`; the frame panels are :mod:`.panels`).

Each task of a run (maps or single scans, any protocol) has its own figures
(:mod:`.figure_files` writes them); a method is given what the rows scored it on.

Every figure uses the look of :mod:`inpaintenv.report.style` (the same depth and error colour
maps, hole drawing and method colours as ``inpaintenv show``), one colour per method for
the whole run. Figures of per-frame metrics (:func:`plot_error_vs_hole_size`) come from
the rows, every scored frame; figures that need pixels (:func:`.panels.frame_panel`,
:func:`plot_error_vs_distance`) take the run's own predictions of a few frames spread over the
drives (:func:`spread_indices`), or run the methods again on them, once per frame for all
(:class:`FramePredictions`), and say which frames in their title.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Mapping, Sequence
from types import SimpleNamespace
from pathlib import Path
from typing import Any

import numpy as np

from ..data.base import DepthDataset
from ..data.inputs import INPUTS, method_input
from ..filling.view import sensor_view
from ..report.results import EvaluationResult
from ..masks import get_protocol
from ..methods.calls import run_method
from ..methods.intervals import interval_source
from ..metrics import Coverage, interpolate_background
from ..report import style
from ..progress import count
from ..report.plots import Line, figure_png, line_figure
from .figure_io import pyplot as _pyplot
from .figure_io import save_figure as _save
from .figure_io import save_png

__all__ = [
    "DISTANCE_BINS", "DISTANCE_FRAMES", "NEAREST_BINS", "FramePredictions", "nearest_distance", "plot_error_vs_distance",
    "plot_error_rejection", "plot_error_vs_hole_size", "plot_error_vs_nearest", "spread_indices",
]

#: Ground-truth range bins (m) of the error-against-distance plot.
DISTANCE_BINS = (0, 10, 20, 30, 40, 50, 60, 80)
#: Frames (spread over the drives) whose pixels error_vs_distance pools.
DISTANCE_FRAMES = 8


def spread_indices(dataset: DepthDataset, k: int, exclude: Collection[int] = ()) -> list[int]:
    """``k`` frame positions spread over the drives: round robin over the drives (in order
    of first appearance), evenly spaced within each drive; never one of ``exclude``
    (e.g. frames that could not be read)."""
    groups = np.asarray(dataset.groups)
    keep = np.ones(len(groups), dtype=bool)
    keep[[i for i in exclude if 0 <= i < len(groups)]] = False
    by_drive = [d for g in dict.fromkeys(groups.tolist()) if len(d := np.flatnonzero((groups == g) & keep))]
    groups = groups[keep]
    share = [len(d) for d in by_drive]
    take = [0] * len(by_drive)
    for _ in range(min(k, len(groups))):  # one more frame for the drive with the fewest taken
        j = min((j for j in range(len(by_drive)) if take[j] < share[j]), key=lambda j: (take[j], j))
        take[j] += 1
    picked = []
    for frames, n in zip(by_drive, take):
        if n:
            picked.append([int(frames[int(p)]) for p in np.linspace(0, len(frames) - 1, n).round()])
    # Interleave so that the first frames come from different drives.
    return [frames[r] for r in range(max(take, default=0)) for frames in picked if r < len(frames)]


def _describe(dataset: DepthDataset, indices: Sequence[int]) -> str:
    drives = len({str(dataset.groups[i]) for i in indices})
    total = len(set(np.asarray(dataset.groups).tolist()))
    return f"{count(len(indices), 'frame')} spread over {drives} of {count(total, 'drive')}"


class FramePredictions:
    """Input, ground truth, hole and every method's reconstruction of a frame, computed once.

    The method is given what the rows scored it on: the map with the hole cut, or for a
    dataset of single scans (``input_kind == "scan"``) the frame's scan with the hole cut
    (:func:`inpaintenv.data.inputs.method_input`).

    Parameters
    ----------
    methods : mapping of str to method
        Name -> callable or estimator.
    dataset : DepthDataset
        The run's frames.
    protocol : str
        Occlusion protocol of the masks.
    seed : int
        Mask seed (frame ``i`` gets ``protocol.mask(shape, seed, i)``, as in the rows).
    unfilled : mapping of str to str, optional
        Method name -> its ``unfilled`` policy in the run (default ``"error"``): with
        ``"interpolate"`` the reconstruction is shown and scored after the KITTI devkit's
        background interpolation, as the rows scored it.
    kept : callable, optional
        ``(name, index) -> the run's own output or None`` (:mod:`.kept_frames`), drawn instead of running again.
    """

    def __init__(
        self, methods: Mapping[str, Any], dataset: DepthDataset, protocol: str, seed: int,
        unfilled: Mapping[str, str] | None = None, coverage: Coverage | None = None,
        kept: Callable[[str, int], np.ndarray | None] | None = None,
    ):
        self.methods, self.dataset, self.seed = methods, dataset, seed
        self.unfilled = dict(unfilled or {})
        self.coverage, self.kept = coverage, (kept if coverage is None else None)  # a width needs the method
        self._bounds: dict[tuple[str, int], tuple[np.ndarray, np.ndarray]] = {}
        self.protocol = get_protocol(protocol)
        self.input_kind = getattr(dataset, "input_kind", "map")
        self._frames: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = {}
        self._preds: dict[tuple[str, int], np.ndarray] = {}

    def _load(self, index: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        if index not in self._frames:
            inputs, gt = self.dataset.load_pairs([index])
            hole = self.protocol.mask(self.dataset.frame_shape, self.seed, index)
            self._frames[index] = (gt[0], hole, method_input(inputs[0], hole, self.input_kind), inputs[0])
        return self._frames[index]

    def frame(self, index: int) -> tuple[np.ndarray, np.ndarray]:
        """``(gt, hole)`` of frame ``index``."""
        gt, hole, _, _ = self._load(index)
        return gt, hole

    def inputs(self, index: int) -> np.ndarray:
        """The measured input of frame ``index`` before the hole is cut (the map itself, or the scan)."""
        return self._load(index)[3]

    def view(self, index: int) -> np.ndarray:
        """Pixels a fill of frame ``index`` can be judged on: all of a map; of a scan, the band of rows
        its LiDAR covers (:func:`inpaintenv.filling.view.sensor_view`), as ``fill --missing`` fills."""
        if INPUTS[self.input_kind].is_map:
            return np.ones(self.dataset.frame_shape, bool)
        return sensor_view(self.inputs(index))

    def method_input(self, index: int) -> np.ndarray:
        """What each method is given for frame ``index``: NaN where it is to fill."""
        return self._load(index)[2]

    def scored(self, index: int) -> np.ndarray:
        """The task's pixels of frame ``index`` that have ground truth: the hole, or under a protocol
        whose task is ``"unmeasured"`` (``densify-v1``) every pixel the input lacks."""
        gt, hole, x, _ = self._load(index)
        return (np.isnan(x) if self.protocol.task == "unmeasured" else hole) & (gt > 0)

    def measured(self, index: int) -> np.ndarray:
        """Pixels the method's input measured (finite and above 0)."""
        x = self.method_input(index)
        return np.nan_to_num(x, nan=0.0) > 0

    def prediction(self, name: str, index: int) -> np.ndarray:
        """Method ``name``'s reconstruction of frame ``index``."""
        if (name, index) not in self._preds and (held := self.held(name, index)) is not None:
            self._preds[(name, index)] = interpolate_background(held[None])[0] if self.policy(name) == "interpolate" else held
        if (name, index) not in self._preds:
            method, x = self.methods[name], self.method_input(index)[None]
            source = interval_source(method, self.coverage, name)
            call = getattr(method, "predict", method)  # a folder of predictions is a callable with intervals
            pred, _ = run_method(SimpleNamespace(predict=source.wrap(call)) if source else method, x, name)
            if source is not None:  # as the rows scored it: on the task's pixels
                task = np.isnan(x) if self.protocol.task == "unmeasured" else self.frame(index)[1][None]
                low, high = source.bounds(x, pred, task)
                self._bounds[(name, index)] = (low[0], high[0])
            if self.policy(name) == "interpolate":
                pred = interpolate_background(pred)
            self._preds[(name, index)] = pred[0]
        return self._preds[(name, index)]

    def held(self, name: str, index: int) -> np.ndarray | None:
        """Method ``name``'s output on frame ``index`` as the run made it (``kept``), or None: run again."""
        return None if self.kept is None else self.kept(name, index)

    def bounds(self, name: str, index: int) -> tuple[np.ndarray, np.ndarray] | None:
        """``(low, high)`` of method ``name``'s interval on frame ``index`` (``coverage`` given and the method
        has one, as the rows scored it), else None."""
        self.prediction(name, index)
        return self._bounds.get((name, index))

    def width(self, name: str, index: int) -> np.ndarray | None:
        """The width of method ``name``'s interval on frame ``index`` (see :meth:`bounds`), else None."""
        return None if (b := self.bounds(name, index)) is None else b[1] - b[0]

    def policy(self, name: str) -> str:
        """Method ``name``'s ``unfilled`` policy in the run."""
        return self.unfilled.get(name, "error")


def plot_error_vs_hole_size(
    result: EvaluationResult, path: str | Path, *, n_bins: int = 6, colours: Mapping[str, Any] | None = None
) -> Path:
    """Mean hole RMSE against the occluded share of the frame, one line per method/protocol.

    From the rows alone (every scored frame, nothing is re-predicted); a protocol other
    than the first is drawn dashed, in the method's colour.
    """
    colours = colours or style.method_colours(result.methods)
    lines = []
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for row in result.rows:
        groups.setdefault((row["method"], row["protocol"]), []).append(row)
    protocols = list(dict.fromkeys(p for _, p in groups))
    fractions = np.array([r["hole_fraction"] for r in result.rows])
    edges = np.quantile(fractions, np.linspace(0, 1, n_bins + 1)) if len(fractions) else np.array([0, 1])
    edges = np.unique(edges)
    for (method, protocol), rows in groups.items():
        f = np.array([r["hole_fraction"] for r in rows])
        e = np.array([np.nan if r["hole_rmse"] is None else r["hole_rmse"] for r in rows], float)
        which = np.clip(np.digitize(f, edges[1:-1]), 0, max(len(edges) - 2, 0))
        xs, ys = [], []
        for b in range(max(len(edges) - 1, 1)):
            sel = (which == b) & np.isfinite(e)
            if sel.any():
                xs.append(100 * f[sel].mean())
                ys.append(e[sel].mean())
        label = method if len(protocols) == 1 else f"{method} ({protocol})"
        lines.append(Line(label, xs, ys, colours.get(method, "black"), ("-", "--", ":", "-.")[protocols.index(protocol) % 4]))
    frames = len({(r["protocol"], r["seed"], r["index"]) for r in result.rows})
    return _save_plot(line_figure(lines, f"every frame-mask of the run ({frames}), from the rows",
                                  "occluded share of the frame (%)", "hole RMSE (m), mean over frames",
                                  legend_columns=2 if len(groups) > 8 else 1), path)


#: (percent of hole pixels kept, row column of the method's curve, of the border baseline's).
REJECTION_POINTS = ((100, "hole_rmse", "hole_rmse"), (90, "rmse_keep_90", "border_rmse_keep_90"),
                    (80, "rmse_keep_80", "border_rmse_keep_80"), (50, "rmse_keep_50", "border_rmse_keep_50"))


def plot_error_rejection(
    result: EvaluationResult, path: str | Path, *, colours: Mapping[str, Any] | None = None
) -> Path:
    """Error-rejection curves from the rows: mean hole RMSE when only the most confident
    100 / 90 / 80 / 50 % of hole pixels are kept, one solid line per method with intervals,
    and dashed in its colour the baseline that keeps the pixels nearest the hole border.

    Only the frames with interval columns (``evaluate(..., intervals=...)``) enter.
    """
    colours = colours or style.method_colours(result.methods)
    lines = []
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for row in result.rows:
        if _finite(row.get("rmse_keep_80")):
            groups.setdefault((row["method"], row["protocol"]), []).append(row)
    protocols = list(dict.fromkeys(p for _, p in groups))
    xs = [x for x, _, _ in REJECTION_POINTS]
    for (method, protocol), rows in groups.items():
        label = method if len(protocols) == 1 else f"{method} ({protocol})"
        for k, (linestyle, what) in enumerate((("-", "most confident"), ("--", "nearest the border"))):
            ys = [float(np.mean([r[cols[k]] for r in rows])) for _, *cols in REJECTION_POINTS]
            lines.append(Line(f"{label}, {what}", xs, ys, colours.get(method, "black"), linestyle))
    frames = len({(r["protocol"], r["seed"], r["index"]) for rows in groups.values() for r in rows})
    coverage = result.meta.get("interval_coverage")
    return _save_plot(line_figure(
        lines, f"{frames} frame-masks with intervals" + (f" (nominal coverage {coverage:g})" if coverage else ""),
        "hole pixels kept (%)", "hole RMSE of the kept pixels (m), mean over frames", invert_x=True), path)


def _save_plot(fig: Any, path: str | Path) -> Path:
    """Encode the line figure ``fig`` (:func:`inpaintenv.report.plots.line_figure`) into the PNG file ``path``."""
    return save_png(figure_png(fig), path)


def _finite(value: Any) -> bool:
    return isinstance(value, (int, float)) and np.isfinite(value)


def has_intervals(result: EvaluationResult) -> bool:
    """Whether some row of ``result`` carries interval scores (so ``error_rejection.png`` is drawn)."""
    return any(_finite(r.get("rmse_keep_80")) for r in result.rows)


def _pooled_rmse(
    predictions: FramePredictions, names: Sequence[str], indices: Sequence[int], edges: np.ndarray,
    value: Callable[[int, np.ndarray], np.ndarray],
) -> tuple[dict[str, list[float]], np.ndarray]:
    """RMSE per bin of ``value(frame, scored pixels)`` per method, the task's pixels pooled over
    ``indices``; and the pixels per bin."""
    nb = len(edges) - 1
    sq = {name: np.zeros(nb) for name in names}
    pixels = np.zeros(nb)
    for i in indices:
        gt, _ = predictions.frame(int(i))
        sel = predictions.scored(int(i))
        which = np.digitize(value(int(i), sel), edges[1:-1])
        pixels += np.bincount(which, minlength=nb)[:nb]
        for name in names:
            err2 = (predictions.prediction(name, int(i))[sel] - gt[sel]) ** 2
            sq[name] += np.bincount(which, weights=err2, minlength=nb)[:nb]
    with np.errstate(invalid="ignore", divide="ignore"):
        return {name: np.sqrt(s / pixels).tolist() for name, s in sq.items()}, pixels


def _task_words(predictions: FramePredictions) -> str:
    return "hole" if predictions.protocol.task == "hole" else "unmeasured-pixel"


def _line_figure(
    values: dict[str, list[float]], xs: np.ndarray, path: str | Path, colours: Mapping[str, Any], *,
    xlabel: str, ylabel: str, title: str, log_x: bool = False,
) -> Path:
    lines = [Line(name, list(xs), v, colours.get(name, "black")) for name, v in values.items()]
    return _save_plot(line_figure(lines, title, xlabel, ylabel, log_x=log_x), path)


def plot_error_vs_distance(
    methods: Mapping[str, Any],
    dataset: DepthDataset,
    indices: Sequence[int],
    path: str | Path,
    *,
    protocol: str = "rect-v1",
    seed: int = 0,
    bins: Sequence[float] = DISTANCE_BINS,
    colours: Mapping[str, Any] | None = None,
    predictions: FramePredictions | None = None,
) -> tuple[Path, dict[str, list[float]]]:
    """RMSE of the task's pixels (the hole, or the unmeasured pixels under ``densify-v1``) per
    ground-truth range bin, pixels pooled over ``indices``: the error by depth.

    The title says which frames: how many, over how many of the drives.
    Returns the figure's path and the plotted values per method.
    """
    predictions = predictions or FramePredictions(methods, dataset, protocol, seed)
    colours = colours or style.method_colours(methods)
    edges = np.asarray(bins, dtype=float)
    values, _ = _pooled_rmse(predictions, list(methods), indices, edges,
                             lambda i, sel: predictions.frame(i)[0][sel])
    return _line_figure(
        values, 0.5 * (edges[:-1] + edges[1:]), path, colours, xlabel="ground-truth depth (m)",
        ylabel=f"{_task_words(predictions)} RMSE (m), pixels pooled",
        title=f"{_describe(dataset, indices)}, {_task_label(predictions)}, seed {seed}"), values


#: Distance bins (pixels) of :func:`plot_error_vs_nearest`: doubling, so near and far gaps both show.
NEAREST_BINS = (0, 2, 4, 8, 16, 32, 64, 128, 256, 100_000)


def nearest_distance(measured: np.ndarray) -> np.ndarray:
    """Per pixel, the Euclidean distance (pixels) to the nearest measured pixel (inf when none is)."""
    import cv2

    if not measured.any():
        return np.full(measured.shape, np.inf, np.float32)
    return cv2.distanceTransform((~measured).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)


def plot_error_vs_nearest(
    methods: Mapping[str, Any],
    dataset: DepthDataset,
    indices: Sequence[int],
    path: str | Path,
    *,
    protocol: str = "rect-v1",
    seed: int = 0,
    bins: Sequence[float] = NEAREST_BINS,
    colours: Mapping[str, Any] | None = None,
    predictions: FramePredictions | None = None,
) -> tuple[Path, dict[str, list[float]]]:
    """RMSE of the task's pixels against their distance (pixels) to the nearest pixel the method's
    input measured, pooled over ``indices``: how fast each method's error grows away from the data.

    Returns the figure's path and the plotted values per method (NaN for an empty bin).
    """
    predictions = predictions or FramePredictions(methods, dataset, protocol, seed)
    colours = colours or style.method_colours(methods)
    edges = np.asarray(bins, dtype=float)
    values, pixels = _pooled_rmse(predictions, list(methods), indices, edges,
                                  lambda i, sel: nearest_distance(predictions.measured(i))[sel])
    keep = pixels > 0
    centres = np.sqrt(np.maximum(edges[:-1], 0.5) * np.minimum(edges[1:], 2 * np.maximum(edges[:-1], 1)))
    values = {name: [v for v, k in zip(vs, keep) if k] for name, vs in values.items()}
    return _line_figure(
        values, centres[keep], path, colours, xlabel="distance to the nearest measured pixel (px)",
        ylabel=f"{_task_words(predictions)} RMSE (m), pixels pooled", log_x=True,
        title=f"{_describe(dataset, indices)}, {_task_label(predictions)}, seed {seed}"), values


def _task_label(predictions: FramePredictions) -> str:
    name = predictions.protocol.name
    return name if INPUTS[predictions.input_kind].is_map else f"{name} on scans"


