"""Where a benchmark figure goes: matplotlib without a display, each file written whole and recorded as
the run's (:mod:`inpaintenv.files.ownership`), and the horizontal colour bar every panel uses."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..files import ownership, write_atomic

__all__ = ["colourbar", "pyplot", "save_figure"]


def pyplot() -> Any:
    """matplotlib's pyplot on the Agg backend (files only)."""
    import matplotlib

    matplotlib.use("Agg", force=False)  # files only; never needs a display
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig: Any, path: str | Path, dpi: int) -> Path:
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
        pyplot().close(fig)
    return path


def colourbar(fig: Any, axes: Any, cmap: str, vmax: float, label: str) -> None:
    """A horizontal colour bar of ``cmap`` on ``[0, vmax]`` under ``axes``."""
    import matplotlib

    mappable = matplotlib.cm.ScalarMappable(norm=matplotlib.colors.Normalize(0.0, vmax), cmap=cmap)
    fig.colorbar(mappable, ax=axes, orientation="horizontal", fraction=0.04, pad=0.02, aspect=50, label=label)
