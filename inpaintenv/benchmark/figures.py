"""Figures of a benchmark: study-style frame panels and error against hole size / range."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..conventions import corrupt
from ..data.base import DepthDataset
from ..evaluate import EvaluationResult, run_method
from ..masks import get_protocol
from ..metrics import frame_metrics

__all__ = ["frame_panel", "plot_error_vs_hole_size", "plot_error_vs_distance", "DISTANCE_BINS"]

#: Ground-truth range bins (m) of the error-against-distance plot.
DISTANCE_BINS = (0, 10, 20, 30, 40, 50, 60, 80)


def _pyplot():
    import matplotlib

    matplotlib.use("Agg", force=False)  # files only; never needs a display
    import matplotlib.pyplot as plt

    return plt


def _save(fig: Any, path: str | Path, dpi: int) -> Path:
    """Write ``fig`` to ``path`` (creating its folder) and free it."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)
    _pyplot().close(fig)
    return path


def _predict(method: Any, x: np.ndarray, name: str) -> np.ndarray:
    pred, _ = run_method(method, x[None], name)
    return pred[0]


def _depth_rgb(depth: np.ndarray, max_depth: float) -> np.ndarray:
    """Colour-map depth (near = warm); pixels without depth are black."""
    plt = _pyplot()
    rgb = plt.get_cmap("turbo_r")(np.clip(np.nan_to_num(depth) / max_depth, 0, 1))[..., :3]
    rgb[~(np.nan_to_num(depth) > 0)] = 0.0
    return rgb


def frame_panel(
    methods: Mapping[str, Any],
    dataset: DepthDataset,
    index: int,
    path: str | Path,
    *,
    protocol: str = "rect-v1",
    seed: int = 0,
    max_depth: float = 80.0,
) -> Path:
    """The study's Fig. 2 for one frame: per method a row of ground truth, input with
    holes in red, prediction and absolute error (holes only), hole/all metrics in the title.
    """
    plt = _pyplot()
    gt = dataset[index]
    hole = get_protocol(protocol).mask(dataset.frame_shape, seed, index)
    x = corrupt(gt, hole)
    n = len(methods)
    h, w = gt.shape
    fig, axes = plt.subplots(n, 4, figsize=(4 * 4.2, n * 4.2 * h / w + 0.6 * n), squeeze=False)
    masked = _depth_rgb(np.where(hole, 0, gt), max_depth)
    masked[hole] = (0.85, 0.1, 0.1)
    for r, (name, method) in enumerate(methods.items()):
        pred = _predict(method, x, name)
        m = frame_metrics(pred, gt, hole, max_depth=max_depth)
        err = np.where(hole & (gt > 0), np.abs(pred - gt), np.nan)
        panels = [
            (_depth_rgb(gt, max_depth), "ground truth"),
            (masked, "input, holes in red"),
            (_depth_rgb(pred, max_depth), f"{name}"),
            (None, f"|error| in holes (max 20 m)"),
        ]
        for c, (img, title) in enumerate(panels):
            ax = axes[r, c]
            if img is None:
                ax.imshow(np.zeros((h, w)), cmap="gray", vmin=0, vmax=1)
                ax.imshow(err, cmap="magma", vmin=0, vmax=20, interpolation="nearest")
            else:
                ax.imshow(img, interpolation="nearest")
            ax.set_title(title, fontsize=9)
            ax.axis("off")
        axes[r, 2].set_title(
            f"{name}\nhole RMSE {float(m['hole_rmse']):.2f} m, PSNR {float(m['hole_psnr']):.1f} dB | "
            f"all {float(m['all_rmse']):.2f} m, {float(m['all_psnr']):.1f} dB",
            fontsize=8,
        )
    fig.suptitle(f"{dataset.frame_ids[index]} — {protocol}, seed {seed}", fontsize=10)
    fig.tight_layout()
    return _save(fig, path, dpi=90)


def plot_error_vs_hole_size(result: EvaluationResult, path: str | Path, *, n_bins: int = 6) -> Path:
    """Mean hole RMSE against the occluded share of the frame, one line per method/protocol."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for row in result.rows:
        groups.setdefault((row["method"], row["protocol"]), []).append(row)
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
        label = method if len({p for _, p in groups}) == 1 else f"{method} ({protocol})"
        ax.plot(xs, ys, marker="o", label=label)
    ax.set_xlabel("occluded share of the frame (%)")
    ax.set_ylabel("hole RMSE (m), mean over frames")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    return _save(fig, path, dpi=100)


def plot_error_vs_distance(
    methods: Mapping[str, Any],
    dataset: DepthDataset,
    indices: Sequence[int],
    path: str | Path,
    *,
    protocol: str = "rect-v1",
    seed: int = 0,
    bins: Sequence[float] = DISTANCE_BINS,
) -> tuple[Path, dict[str, list[float]]]:
    """Hole RMSE per ground-truth range bin (pixels pooled over ``indices``).

    Returns the figure's path and the plotted values per method.
    """
    plt = _pyplot()
    proto = get_protocol(protocol)
    edges = np.asarray(bins, dtype=float)
    sq = {name: np.zeros(len(edges) - 1) for name in methods}
    count = np.zeros(len(edges) - 1)
    for i in indices:
        gt = dataset[int(i)]
        hole = proto.mask(dataset.frame_shape, seed, int(i))
        sel = hole & (gt > 0)
        which = np.digitize(gt[sel], edges[1:-1])
        count += np.bincount(which, minlength=len(edges) - 1)[: len(edges) - 1]
        x = corrupt(gt, hole)
        for name, method in methods.items():
            err2 = (_predict(method, x, name)[sel] - gt[sel]) ** 2
            sq[name] += np.bincount(which, weights=err2, minlength=len(edges) - 1)[: len(edges) - 1]
    with np.errstate(invalid="ignore", divide="ignore"):
        values = {name: np.sqrt(s / count).tolist() for name, s in sq.items()}
    centres = 0.5 * (edges[:-1] + edges[1:])
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for name, v in values.items():
        ax.plot(centres, v, marker="o", label=name)
    ax.set_xlabel("ground-truth depth (m)")
    ax.set_ylabel("hole RMSE (m), pixels pooled")
    ax.set_title(f"{len(indices)} frames, {protocol}, seed {seed}", fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    return _save(fig, path, dpi=100), values
