"""Writing the outputs of one filled input: depth files, interval files, point files."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..conventions import DEPTH_LIMIT
from ..data.calibration import Calibration
from ..data.depth_files import write_depth_file
from ..data.io import KITTI_DEPTH_SCALE
from ..data.projection import depth_to_points, write_points_bin, write_points_ply
from .read import Item

__all__ = ["write_outputs"]


def _atomic(path: Path, write: Callable[[Path], None]) -> None:
    """``write`` a temporary file beside ``path`` (same suffix, hidden), then rename it over ``path``."""
    import os

    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}{path.suffix}")
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def write_outputs(item: Item, arrays: tuple[np.ndarray, ...], calibration: Callable[[], Calibration]) -> None:
    """Write every output of one filled input, each atomically.

    Parameters
    ----------
    item : Item
        The input, read.
    arrays : tuple of numpy.ndarray
        The filled map, then with an interval its low and high.
    calibration : callable
        Gives the run's calibration (scans with point outputs only).
    """
    assert item.fill is not None
    filled = arrays[0]
    for pair in item.job.intervals:
        for path, bound in zip(pair, arrays[1:]):
            if path.suffix.lower() == ".png":  # the PNG range: the interval's top end is cut there
                bound = np.minimum(bound, np.float32(DEPTH_LIMIT))
            _atomic(path, lambda tmp, data=bound: write_depth_file(tmp, data))
    for path in item.job.outputs:
        suffix = path.suffix.lower()
        if suffix in (".png", ".npy"):
            data = filled
            tiny = item.fill & (filled < 1 / KITTI_DEPTH_SCALE)
            if suffix == ".png" and tiny.any():  # below half a PNG step it would be stored as 0 = no data
                data = np.where(tiny, np.float32(1 / KITTI_DEPTH_SCALE), filled)
            _atomic(path, lambda tmp, data=data: write_depth_file(tmp, data))
        else:
            new = depth_to_points(filled, calibration(), mask=item.fill)
            pts = np.vstack([item.points, np.hstack([new, np.zeros((len(new), 1))]).astype(np.float32)])
            writer = write_points_bin if suffix == ".bin" else write_points_ply
            _atomic(path, lambda tmp, pts=pts, writer=writer: writer(tmp, pts))
