"""Figures of a benchmark: study-style frame panels and error against hole size / range.

Every figure uses the look of :mod:`inpaintenv.report.style` (the same depth and error colour
maps, hole drawing and method colours as ``inpaintenv show``), one colour per method for
the whole run. Figures of per-frame metrics (:func:`plot_error_vs_hole_size`) come from
the rows, every scored frame; figures that need pixels (:func:`frame_panel`,
:func:`plot_error_vs_distance`) run the methods again on a few frames spread over the
drives (:func:`spread_indices`), once per frame for both (:class:`FramePredictions`), and
say which frames in their title.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Callable, Collection, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

import inpaintenv

from ..conventions import corrupt
from ..data.base import DepthDataset
from ..report.results import EvaluationResult
from ..masks import get_protocol
from ..methods.calls import run_method
from ..metrics import frame_metrics, interpolate_background
from ..report import style
from ..exceptions import FileTooLargeError, JSONFileError
from ..files import read_json, write_atomic, write_text_atomic
from ..progress import count
from ..files import ownership

__all__ = [
    "DISTANCE_BINS", "DISTANCE_FRAMES", "FramePredictions", "frame_panel", "plot_error_vs_distance",
    "plot_error_rejection", "plot_error_vs_hole_size", "spread_indices", "write_figures",
]

#: Ground-truth range bins (m) of the error-against-distance plot.
DISTANCE_BINS = (0, 10, 20, 30, 40, 50, 60, 80)
#: Frames (spread over the drives) whose pixels error_vs_distance pools.
DISTANCE_FRAMES = 8


def _pyplot():
    import matplotlib

    matplotlib.use("Agg", force=False)  # files only; never needs a display
    import matplotlib.pyplot as plt

    return plt


def _save(fig: Any, path: str | Path, dpi: int) -> Path:
    """Write ``fig`` to ``path`` whole or not at all (creating its folder) and free it.

    In a run folder (:func:`.ownership.run_root`) the file is recorded as the run's
    first, and a file there that no run wrote is refused, never replaced.
    """
    path = Path(path)
    try:
        root = ownership.run_root(path.parent)
        if (root / ownership.LEDGER).exists():
            ownership.claim(root, path.resolve().relative_to(root.resolve()))
        write_atomic(path, lambda tmp: fig.savefig(tmp, dpi=dpi, format=path.suffix.lstrip(".") or "png"))
    finally:
        _pyplot().close(fig)
    return path


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
    """Ground truth, hole and every method's reconstruction of a frame, computed once.

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
    """

    def __init__(
        self, methods: Mapping[str, Any], dataset: DepthDataset, protocol: str, seed: int,
        unfilled: Mapping[str, str] | None = None,
    ):
        self.methods, self.dataset, self.seed = dict(methods), dataset, seed
        self.unfilled = dict(unfilled or {})
        self.protocol = get_protocol(protocol)
        self._frames: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self._preds: dict[tuple[str, int], np.ndarray] = {}

    def frame(self, index: int) -> tuple[np.ndarray, np.ndarray]:
        """``(gt, hole)`` of frame ``index``."""
        if index not in self._frames:
            gt = self.dataset[index]
            self._frames[index] = (gt, self.protocol.mask(self.dataset.frame_shape, self.seed, index))
        return self._frames[index]

    def prediction(self, name: str, index: int) -> np.ndarray:
        """Method ``name``'s reconstruction of frame ``index``."""
        if (name, index) not in self._preds:
            gt, hole = self.frame(index)
            pred, _ = run_method(self.methods[name], corrupt(gt, hole)[None], name)
            if self.policy(name) == "interpolate":
                pred = interpolate_background(pred)
            self._preds[(name, index)] = pred[0]
        return self._preds[(name, index)]

    def policy(self, name: str) -> str:
        """Method ``name``'s ``unfilled`` policy in the run."""
        return self.unfilled.get(name, "error")


def _colourbar(fig: Any, axes: Any, cmap: str, vmax: float, label: str) -> None:
    import matplotlib

    mappable = matplotlib.cm.ScalarMappable(norm=matplotlib.colors.Normalize(0.0, vmax), cmap=cmap)
    fig.colorbar(mappable, ax=axes, orientation="horizontal", fraction=0.04, pad=0.02, aspect=50, label=label)


def frame_panel(
    methods: Mapping[str, Any],
    dataset: DepthDataset,
    index: int,
    path: str | Path,
    *,
    protocol: str = "rect-v1",
    seed: int = 0,
    max_depth: float = 80.0,
    colours: Mapping[str, Any] | None = None,
    predictions: FramePredictions | None = None,
) -> Path:
    """The study's Fig. 2 for one frame, in the look of ``inpaintenv show``.

    Per method a row of input (holes hatched), ground truth, reconstruction (method name
    in its run colour, hole/all metrics) and absolute error in the holes; holes outlined on
    every tile; one colour bar for depth and one for the error (robust scale shared by the
    rows, :func:`inpaintenv.report.style.error_scale`), both in metres.
    """
    plt = _pyplot()
    predictions = predictions or FramePredictions(methods, dataset, protocol, seed)
    colours = colours or style.method_colours(methods)
    gt, hole = predictions.frame(index)
    scored = hole & (gt > 0)
    preds = {name: predictions.prediction(name, index) for name in methods}
    error_max = style.error_scale([np.abs(p - gt)[scored] for p in preds.values()])
    n = len(methods)
    h, w = gt.shape
    dpi, tile_inches = 90, 4.2
    fig, axes = plt.subplots(
        n, 4, figsize=(4 * tile_inches, n * tile_inches * h / w + 0.5 * n + 1.2), squeeze=False
    )
    # Tiles are shown shrunk: hole lines as wide on the page as in `inpaintenv show`.
    k = w / (tile_inches * dpi)
    inp = style.draw_holes(style.depth_rgb(np.where(hole, 0.0, gt), max_depth), hole, hatch=True, scale=k)
    truth = style.draw_holes(style.depth_rgb(gt, max_depth), hole, scale=k)
    for r, (name, pred) in enumerate(preds.items()):
        m = frame_metrics(pred, gt, hole, max_depth=max_depth, unfilled=predictions.policy(name))
        scores = (
            f"{name}\nhole RMSE {float(m['hole_rmse']):.2f} m, PSNR {float(m['hole_psnr']):.1f} dB | "
            f"all {float(m['all_rmse']):.2f} m, {float(m['all_psnr']):.1f} dB"
        )
        tiles = [
            (inp, "input (holes hatched)"),
            (truth, "ground truth (grey = no data)"),
            (style.draw_holes(style.depth_rgb(pred, max_depth), hole, scale=k), scores),
            (style.draw_holes(style.error_rgb(np.abs(pred - gt), scored, error_max), hole, scale=k),
             f"|error| in the holes, 0-{error_max:g} m"),
        ]
        for c, (img, title) in enumerate(tiles):
            ax = axes[r, c]
            ax.imshow(img, interpolation="nearest")
            ax.set_title(title, fontsize=8, color=colours.get(name, "black") if c == 2 else "black")
            ax.axis("off")
    fig.suptitle(f"{dataset.frame_ids[index]} — {protocol}, seed {seed}", fontsize=10)
    fig.tight_layout(rect=(0, 0.09, 1, 1))
    _colourbar(fig, axes[:, :3].ravel().tolist(), style.DEPTH_CMAP, max_depth, "depth (m)")
    _colourbar(fig, axes[:, 3].ravel().tolist(), style.ERROR_CMAP, error_max, "|error| (m)")
    return _save(fig, path, dpi=dpi)


def plot_error_vs_hole_size(
    result: EvaluationResult, path: str | Path, *, n_bins: int = 6, colours: Mapping[str, Any] | None = None
) -> Path:
    """Mean hole RMSE against the occluded share of the frame, one line per method/protocol.

    From the rows alone (every scored frame, nothing is re-predicted); a protocol other
    than the first is drawn dashed, in the method's colour.
    """
    plt = _pyplot()
    colours = colours or style.method_colours(result.methods)
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
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
        ax.plot(xs, ys, marker="o", label=label, color=colours.get(method),
                linestyle=("-", "--", ":", "-.")[protocols.index(protocol) % 4])
    frames = len({(r["protocol"], r["seed"], r["index"]) for r in result.rows})
    ax.set_title(f"every frame-mask of the run ({frames}), from the rows", fontsize=9)
    ax.set_xlabel("occluded share of the frame (%)")
    ax.set_ylabel("hole RMSE (m), mean over frames")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2 if len(groups) > 8 else 1)
    fig.tight_layout()
    return _save(fig, path, dpi=100)


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
    plt = _pyplot()
    colours = colours or style.method_colours(result.methods)
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
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
            ax.plot(xs, ys, marker="o", linestyle=linestyle, color=colours.get(method), label=f"{label}, {what}")
    frames = len({(r["protocol"], r["seed"], r["index"]) for rows in groups.values() for r in rows})
    coverage = result.meta.get("interval_coverage")
    ax.set_title(f"{frames} frame-masks with intervals" + (f" (nominal coverage {coverage:g})" if coverage else ""),
                 fontsize=9)
    ax.set_xlabel("hole pixels kept (%)")
    ax.set_ylabel("hole RMSE of the kept pixels (m), mean over frames")
    ax.invert_xaxis()
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    return _save(fig, path, dpi=100)


def _finite(value: Any) -> bool:
    return isinstance(value, (int, float)) and np.isfinite(value)


def has_intervals(result: EvaluationResult) -> bool:
    """Whether some row of ``result`` carries interval scores (so ``error_rejection.png`` is drawn)."""
    return any(_finite(r.get("rmse_keep_80")) for r in result.rows)


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
    """Hole RMSE per ground-truth range bin (pixels pooled over ``indices``).

    The title says which frames: how many, over how many of the drives.
    Returns the figure's path and the plotted values per method.
    """
    plt = _pyplot()
    predictions = predictions or FramePredictions(methods, dataset, protocol, seed)
    colours = colours or style.method_colours(methods)
    edges = np.asarray(bins, dtype=float)
    sq = {name: np.zeros(len(edges) - 1) for name in methods}
    count = np.zeros(len(edges) - 1)
    for i in indices:
        gt, hole = predictions.frame(int(i))
        sel = hole & (gt > 0)
        which = np.digitize(gt[sel], edges[1:-1])
        count += np.bincount(which, minlength=len(edges) - 1)[: len(edges) - 1]
        for name in methods:
            err2 = (predictions.prediction(name, int(i))[sel] - gt[sel]) ** 2
            sq[name] += np.bincount(which, weights=err2, minlength=len(edges) - 1)[: len(edges) - 1]
    with np.errstate(invalid="ignore", divide="ignore"):
        values = {name: np.sqrt(s / count).tolist() for name, s in sq.items()}
    centres = 0.5 * (edges[:-1] + edges[1:])
    fig, ax = plt.subplots(figsize=(6.4, 4.6))
    for name, v in values.items():
        ax.plot(centres, v, marker="o", label=name, color=colours.get(name))
    ax.set_xlabel("ground-truth depth (m)")
    ax.set_ylabel("hole RMSE (m), pixels pooled")
    ax.set_title(f"{_describe(dataset, indices)}, {protocol}, seed {seed}", fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    return _save(fig, path, dpi=100), values


def _stamp(result: EvaluationResult, settings: dict[str, Any]) -> str:
    """Digest of what the figures show: every row's identity and hole RMSE, and the settings."""
    digest = hashlib.sha1(json.dumps(settings, sort_keys=True).encode())
    for r in result.rows:
        digest.update(f"{r['method']}|{r['protocol']}|{r['seed']}|{r['index']}|{r['hole_rmse']!r}\n".encode())
        if "rmse_keep_80" in r:  # only rows with intervals: other runs keep the stamp they had
            digest.update(f"{r['rmse_keep_80']!r}\n".encode())
    return digest.hexdigest()


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
) -> list[Path]:
    """Write a run's figures into ``out_dir``; skip them when they already show these rows.

    Parameters
    ----------
    result : EvaluationResult
        The run's rows (``error_vs_hole_size.png`` and, when rows carry intervals, ``error_rejection.png`` come from them).
    methods : mapping of str to zero-argument callable
        Name -> a function returning the built method (built only if a figure needs it).
    dataset : DepthDataset
        The run's frames.
    out_dir : path
        Folder of the figures; ``figures.json`` there records what they show.
    panel_methods : sequence of str
        Methods drawn in the frame panels and ``error_vs_distance.png``.
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
    """
    out = Path(out_dir)
    colours = style.method_colours(result.methods)  # one colour per method, in run order
    indices = spread_indices(dataset, max(n_panels, DISTANCE_FRAMES), exclude)
    panels = indices[:n_panels]
    names = [out / f"frame_{i:04d}.png" for i in panels] + [out / "error_vs_hole_size.png", out / "error_vs_distance.png"]
    if has_intervals(result):
        names.append(out / "error_rejection.png")
    settings = {"panel_methods": list(panel_methods), "panels": panels, "distance": indices,
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
    plot_error_vs_hole_size(result, out / "error_vs_hole_size.png", colours=colours)
    if has_intervals(result):
        plot_error_rejection(result, out / "error_rejection.png", colours=colours)
    ms = {e["method"]: e["ms_per_frame"] for e in result.group_table(("method",))}
    seconds = sum(ms.get(n, 0.0) for n in panel_methods) * len(indices) / 1000.0
    log(
        f"figures: running {count(len(panel_methods), 'method')} again on {_describe(dataset, indices)} "
        f"(about {seconds:.0f} s): the frame panels and error_vs_distance need pixels, which the rows do "
        "not keep; error_vs_hole_size comes from the rows"
    )
    built = {name: methods[name]() for name in panel_methods}
    predictions = FramePredictions(built, dataset, protocol, seed, unfilled)
    for i in panels:
        frame_panel(built, dataset, i, out / f"frame_{i:04d}.png", protocol=protocol, seed=seed,
                    colours=colours, predictions=predictions)
    plot_error_vs_distance(built, dataset, indices, out / "error_vs_distance.png", protocol=protocol, seed=seed,
                           colours=colours, predictions=predictions)
    write_text_atomic(stamp_path, json.dumps({"stamp": stamp, **settings}, indent=1))
    return names
