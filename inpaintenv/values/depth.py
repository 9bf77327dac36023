"""What a depth map may be: each value by :func:`inpaintenv.conventions.check_depth`, the frame's scale here.

Each value is checked by :func:`~inpaintenv.conventions.check_depth` (finite, 0 or between
1 mm and 255.996 m; re-exported here). A frame of an outdoor LiDAR whose every measurement
is under :data:`MIN_FRAME_DEPTH` is not in metres: a 16-bit PNG of plain metres (5 m stored
as 5, read as 5/256 m), a mask saved as depth, or an array normalised to 0..1 or in
kilometres. :func:`check_metres_scale` refuses it, saying what the values look like; it is
called by :func:`~inpaintenv.data.depth_files.read_depth_file`, which reads ``fill``'s inputs.
"""

from __future__ import annotations

import numpy as np

from ..conventions import DEPTH_LIMIT, check_depth
from ..exceptions import DepthFormatError

__all__ = ["MIN_FRAME_DEPTH", "check_depth", "check_metres_scale"]

#: A frame whose every measured depth is below this (metres) is not an outdoor LiDAR's: KITTI's
#: nearest returns are a few metres away and every frame reaches tens of metres.
MIN_FRAME_DEPTH: float = 1.0


def check_metres_scale(depth: np.ndarray, where: str, *, png: bool) -> None:
    """Refuse a depth frame whose every measurement is under :data:`MIN_FRAME_DEPTH` metres.

    Parameters
    ----------
    depth : numpy.ndarray
        Checked depth (:func:`check_depth`), metres; 0 = no measurement, NaN = fill.
    where : str
        The file, for the message.
    png : bool
        Read from a KITTI 16-bit PNG (metres x 256): the message gives the stored values.

    Raises
    ------
    DepthFormatError
        Saying the largest depth, what that suggests and how to give metres. A frame with no
        measurement at all passes (there is no scale to judge).
    """
    with np.errstate(invalid="ignore"):
        top = float(np.nanmax(depth, initial=0.0))
    if top == 0 or top >= MIN_FRAME_DEPTH:
        return
    if png:
        stored = round(top * 256)
        raise DepthFormatError(
            f"{where}: every measured pixel is under {MIN_FRAME_DEPTH:g} m (the largest {top:.4g} m, stored as {stored}):"
            f" this looks like a 16-bit PNG of plain metres (or a mask), not KITTI's metres x 256; store metres x 256 "
            f"(e.g. {stored} m as {stored * 256}, up to {DEPTH_LIMIT:.3f} m) or give a float .npy of metres")
    raise DepthFormatError(
        f"{where}: every measured depth is under {MIN_FRAME_DEPTH:g} m (the largest {top:.4g}): depth is in metres, "
        "not normalised to 0..1 or in kilometres; multiply by the scale that gives metres")
