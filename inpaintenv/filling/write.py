"""Writing the outputs of one filled input: depth files, interval files, point files, the preview.

Every file goes through :func:`inpaintenv.files.write_atomic` (an exclusive, unpredictable
temporary name in the target's folder, renamed over the target; never written through a
link, nor into a folder of ``--out`` that is one: ``within=``). The interval files follow
one encoding in both formats (docs/fill.md): at a filled pixel ``low`` is at least
:data:`LOW_FLOOR` and ``high`` at most the PNG limit, so 0 always means "no interval here"
(a pixel neither measured nor filled), as 0 means "no measurement" in the depth file; a
PNG rounds ``low`` down and ``high`` up to its 1/256 m grid, so each stays a bound of the
depth stored beside it.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..conventions import DEPTH_LIMIT
from ..data.calibration import Calibration
from ..data.depth_files import write_depth_file
from ..data.io import KITTI_DEPTH_SCALE
from ..data.projection import depth_to_points, write_points_bin, write_points_ply
from ..files import write_atomic
from .preview import write_preview
from .read import Item

__all__ = ["LOW_FLOOR", "interval_bounds", "write_outputs"]

#: The smallest lower bound written at a filled pixel (one PNG step, 1/256 m): no depth a LiDAR
#: measures lies below it (KITTI's projection drops points nearer than 0.1 m), so it stays a bound.
LOW_FLOOR = np.float32(1 / KITTI_DEPTH_SCALE)


def interval_bounds(low: np.ndarray, high: np.ndarray, fill: np.ndarray, png: bool) -> tuple[np.ndarray, np.ndarray]:
    """``low`` and ``high`` as written: at ``fill`` pixels in ``[LOW_FLOOR, DEPTH_LIMIT]``, on a PNG's grid outward.

    Parameters
    ----------
    low, high : numpy.ndarray
        The interval (the measurement at measured pixels, 0 where nothing was measured or filled).
    fill : numpy.ndarray of bool
        The filled pixels; the others are left as they are.
    png : bool
        Round ``low`` down and ``high`` up to multiples of 1/256 m.

    Returns
    -------
    tuple of numpy.ndarray
        The bounds to write, in ``low``'s dtype.
    """
    limit = np.float32(DEPTH_LIMIT)
    lo = np.clip(low[fill].astype(np.float64), LOW_FLOOR, limit)
    hi = np.clip(high[fill].astype(np.float64), lo, limit)
    if png:
        lo = np.maximum(np.floor(lo * KITTI_DEPTH_SCALE), 1) / KITTI_DEPTH_SCALE
        hi = np.minimum(np.ceil(hi * KITTI_DEPTH_SCALE), 65535) / KITTI_DEPTH_SCALE
    out_low, out_high = low.copy(), high.copy()
    out_low[fill], out_high[fill] = lo, hi
    return out_low, out_high


def _depth_data(filled: np.ndarray, fill: np.ndarray, png: bool) -> np.ndarray:
    """The filled map as written; in a PNG a filled depth below half a step would be stored as 0 = no data."""
    tiny = fill & (filled < LOW_FLOOR)
    return np.where(tiny, LOW_FLOOR, filled).astype(filled.dtype, copy=False) if png and tiny.any() else filled


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
    if item.job.preview is not None:
        width = arrays[2] - arrays[1] if len(arrays) == 3 else None
        write_atomic(item.job.preview, lambda tmp: write_preview(tmp, filled, item.fill, width),
                     "preview", within=item.job.out)
    for pair in item.job.intervals:
        png = pair[0].suffix.lower() == ".png"
        for path, bound in zip(pair, interval_bounds(arrays[1], arrays[2], item.fill, png)):
            write_atomic(path, lambda tmp, data=bound: write_depth_file(tmp, data), "interval file",
                         within=item.job.out)
    for path in item.job.outputs:
        suffix = path.suffix.lower()
        if suffix in (".png", ".npy"):
            data = _depth_data(filled, item.fill, suffix == ".png")
            write_atomic(path, lambda tmp, data=data: write_depth_file(tmp, data), "filled depth file",
                         within=item.job.out)
        else:
            new = depth_to_points(filled, calibration(), mask=item.fill)
            pts = np.vstack([item.points, np.hstack([new, np.zeros((len(new), 1))]).astype(np.float32)])
            writer = write_points_bin if suffix == ".bin" else write_points_ply
            write_atomic(path, lambda tmp, pts=pts, writer=writer: writer(tmp, pts), "point file",
                         within=item.job.out)
