"""The colour picture ``fill --preview`` writes beside a filled input: what a person looks at.

A fill's depth files are 16-bit PNGs in 1/256 m (or float ``.npy``), which show black in an
image viewer. The preview is one 8-bit colour PNG: the input, the fill, and with
``--confidence`` the width of the interval, stacked, each under its label; input and fill on
one depth scale in metres with one colour bar (:data:`inpaintenv.report.style.DEPTH_CMAP`,
perceptually uniform), the width on its own scale (:data:`~inpaintenv.report.style.ERROR_CMAP`);
pixels without a value grey. Drawn by matplotlib, saved with its own ``savefig``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..report import style

__all__ = ["write_preview"]
#: Width of the picture in inches at :data:`_DPI` (about 1100 pixels: a KITTI frame at 0.9x).
_WIDTH, _DPI = 11.0, 100


def _top(values: np.ndarray, floor: float) -> float:
    """A round top of a colour scale: the 99th percentile of the values, at least ``floor``."""
    finite = values[np.isfinite(values) & (values > 0)]
    return style.error_scale(finite, 99.0) if finite.size else floor


def write_preview(path: Path, filled: np.ndarray, fill: np.ndarray, width: np.ndarray | None = None) -> None:
    """Draw the preview of one filled input and save it to ``path`` (a temporary name of the caller's).

    Parameters
    ----------
    path : pathlib.Path
        The PNG to write.
    filled : numpy.ndarray
        The fill as written, metres (measured pixels kept; 0 = none).
    fill : numpy.ndarray of bool
        The pixels the fill filled: the input is ``filled`` without them.
    width : numpy.ndarray, optional
        ``high - low`` of the interval (metres), shown at the filled pixels.
    """
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    shown = np.where(filled > 0, filled, 0.0)
    vmax = _top(shown, 1.0)
    tiles = [(style.depth_rgb(np.where(fill, 0.0, shown), vmax), "input (grey = no measurement, or to fill)"),
             (style.depth_rgb(shown, vmax), f"fill: {int(fill.sum()):,} pixels filled")]
    wmax = None
    if width is not None:
        w = np.where(fill, width, np.nan)
        wmax = _top(w, 1.0)
        tiles.append((style.error_rgb(np.nan_to_num(w, nan=0.0), fill, wmax), "interval width at the filled pixels"))
    h, w_px = filled.shape
    tile_h = _WIDTH * h / w_px
    height = len(tiles) * (tile_h + 0.3) + 0.9 * (1 + (wmax is not None))
    fig, axes = plt.subplots(len(tiles), 1, figsize=(_WIDTH, height), squeeze=False)
    try:
        for ax, (img, label) in zip(axes[:, 0], tiles):
            ax.imshow(img, interpolation="nearest")
            ax.set_title(label, fontsize=9)
            ax.axis("off")
        bars = [(axes[:2, 0].tolist(), style.DEPTH_CMAP, vmax, "depth (m)")]
        if wmax is not None:
            bars.append(([axes[2, 0]], style.ERROR_CMAP, wmax, "interval width (m)"))
        for where, cmap, top, label in bars:
            mappable = matplotlib.cm.ScalarMappable(norm=matplotlib.colors.Normalize(0.0, top), cmap=cmap)
            fig.colorbar(mappable, ax=where, orientation="horizontal", fraction=0.05, pad=0.04, aspect=60, label=label)
        fig.savefig(path, format="png", dpi=_DPI, bbox_inches="tight")
    finally:
        plt.close(fig)
