"""Pictures of what ``inpaintenv show`` is given: a depth map (with its interval width) and a point cloud.

Drawn in the look of every figure (:mod:`.style`): depth in :data:`~.style.DEPTH_CMAP` on one
scale in metres with its colour bar, widths in :data:`~.style.ERROR_CMAP`, no data grey. A point
cloud (LiDAR frame: x forward, y left, z up) gets two views: from above (x-y, coloured by
height) and as a camera at the sensor looking forward would see it (coloured by range).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from . import style

__all__ = ["depth_figure", "points_figure"]


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def _top(values: np.ndarray, floor: float = 1.0) -> float:
    finite = values[np.isfinite(values) & (values > 0)]
    return style.error_scale(finite, 99.0) if finite.size else floor


def _bar(fig: Any, axes: Any, cmap: str, top: float, label: str, low: float = 0.0) -> None:
    import matplotlib

    mappable = matplotlib.cm.ScalarMappable(norm=matplotlib.colors.Normalize(low, top), cmap=cmap)
    fig.colorbar(mappable, ax=axes, orientation="horizontal", fraction=0.05, pad=0.06, aspect=60, label=label)


def depth_figure(depth: np.ndarray, title: str, width: np.ndarray | None = None) -> Any:
    """A figure of a depth map (metres, 0 or NaN = none) and, when given, its interval width (metres).

    Returns the matplotlib figure; the caller saves and closes it.
    """
    plt = _pyplot()
    d = np.nan_to_num(np.asarray(depth, np.float32), nan=0.0)
    top = _top(d)
    tiles = [(style.depth_rgb(d, top), f"{title}: {int((d > 0).sum()):,} pixels with depth (grey = none)")]
    if width is not None:
        w = np.nan_to_num(np.asarray(width, np.float32), nan=0.0)
        tiles.append((style.error_rgb(w, w > 0, _top(w)), "interval width (high - low)"))
    h, wpx = d.shape
    fig, axes = plt.subplots(len(tiles), 1, figsize=(11, len(tiles) * (11 * h / wpx + 0.4) + 1.0 * len(tiles)),
                             squeeze=False)
    for ax, (img, label) in zip(axes[:, 0], tiles):
        ax.imshow(img, interpolation="nearest")
        ax.set_title(label, fontsize=9)
        ax.axis("off")
    _bar(fig, [axes[0, 0]], style.DEPTH_CMAP, top, "depth (m)")
    if width is not None:
        _bar(fig, [axes[1, 0]], style.ERROR_CMAP, _top(np.nan_to_num(width, nan=0.0)), "interval width (m)")
    return fig


def points_figure(points: np.ndarray, title: str, *, max_range: float = 80.0) -> Any:
    """A figure of a point cloud (``(N, 3+)``, LiDAR frame): a top-down view and a forward camera view."""
    plt = _pyplot()
    xyz = np.asarray(points, np.float32)[:, :3]
    rng = np.linalg.norm(xyz, axis=1)
    keep = rng <= max_range
    xyz, rng = xyz[keep], rng[keep]
    fig = plt.figure(figsize=(11, 9.5))
    top_ax = fig.add_axes((0.08, 0.42, 0.84, 0.52))
    z_low, z_high = np.percentile(xyz[:, 2], [1, 99]) if len(xyz) else (0.0, 1.0)
    top_ax.scatter(-xyz[:, 1], xyz[:, 0], c=np.clip(xyz[:, 2], z_low, z_high), s=0.2, cmap="cividis",
                   linewidths=0, rasterized=True)
    top_ax.set_aspect("equal")
    top_ax.set_xlabel("right (m)")
    top_ax.set_ylabel("forward (m)")
    top_ax.set_title(f"{title}: {len(xyz):,} points within {max_range:g} m, from above (colour: height)", fontsize=9)
    _bar(fig, [top_ax], "cividis", float(z_high), "height (m)", low=float(z_low))
    cam = fig.add_axes((0.08, 0.04, 0.84, 0.22))
    ahead = xyz[:, 0] > 0.5
    u, v = -xyz[ahead, 1] / xyz[ahead, 0], xyz[ahead, 2] / xyz[ahead, 0]
    view = (np.abs(u) < 1.15) & (np.abs(v) < 0.45)  # about 98 degrees across, 48 up and down
    order = np.argsort(-rng[ahead][view])  # far first, so near points are drawn over them
    cam.scatter(u[view][order], v[view][order], c=rng[ahead][view][order], s=0.3, cmap=style.DEPTH_CMAP, vmin=0,
                vmax=max_range, linewidths=0, rasterized=True)
    cam.set_xlim(-1.15, 1.15)
    cam.set_ylim(-0.45, 0.45)
    cam.set_aspect("equal")
    cam.set_xticks([])
    cam.set_yticks([])
    cam.set_title("as a camera at the sensor looking forward sees it (colour: range)", fontsize=9)
    _bar(fig, [cam], style.DEPTH_CMAP, max_range, "range (m)")
    return fig
