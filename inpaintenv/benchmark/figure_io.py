"""Where a benchmark figure goes: matplotlib without a display, each file (a matplotlib figure or PNG
bytes) written whole and recorded as the run's (:mod:`inpaintenv.files.ownership`)."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np

from ..files import ownership, write_atomic

__all__ = ["figure_png", "pyplot", "save_figure", "save_png"]


def pyplot() -> Any:
    """matplotlib's pyplot on the Agg backend (files only)."""
    import matplotlib

    matplotlib.use("Agg", force=False)  # files only; never needs a display
    import matplotlib.pyplot as plt

    return plt


def _claim(path: Path) -> None:
    """In a run folder (:func:`.ownership.run_root`) record ``path`` as the run's; a file there that no run
    wrote is refused, never replaced."""
    root = ownership.run_root(path.parent)
    if (root / ownership.LEDGER).exists():
        ownership.claim(root, path.resolve().relative_to(root.resolve()))


def save_figure(fig: Any, path: str | Path, dpi: int) -> Path:
    """Write ``fig`` to ``path`` whole or not at all (creating its folder) and free it.

    In a run folder (:func:`.ownership.run_root`) the file is recorded as the run's
    first, and a file there that no run wrote is refused, never replaced. A PNG is
    encoded as :func:`figure_png` does.
    """
    path = Path(path)
    fmt = path.suffix.lstrip(".") or "png"
    try:
        _claim(path)
        if fmt == "png":
            data = figure_png(fig, dpi)
            write_atomic(path, lambda tmp: tmp.write_bytes(data))
        else:
            write_atomic(path, lambda tmp: fig.savefig(tmp, dpi=dpi, format=fmt))
    finally:
        if "matplotlib.pyplot" in sys.modules:  # a figure pyplot made is freed; a bare Figure has no manager
            pyplot().close(fig)
    return path


def figure_png(fig: Any, dpi: float) -> bytes:
    """``fig`` drawn by Agg at ``dpi`` as PNG bytes (:func:`inpaintenv.report.raster.png_bytes`: fastest zlib
    level, no row filter: a figure's few colours compress as well unfiltered, in a fifth of ``savefig``'s
    encoding time)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from ..report.raster import png_bytes

    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    fig.set_dpi(dpi)
    canvas.draw()
    return png_bytes(np.asarray(canvas.buffer_rgba()))


def save_png(data: bytes, path: str | Path) -> Path:
    """Write PNG ``data`` (e.g. :func:`inpaintenv.report.plots.figure_png`) to ``path`` as :func:`save_figure` does."""
    path = Path(path)
    _claim(path)
    write_atomic(path, lambda tmp: tmp.write_bytes(data))
    return path

