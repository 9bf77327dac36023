"""The KITTI depth-completion devkit's background interpolation, reproduced.

The devkit (``devkit/cpp/io_depth.h``) fills a prediction's unfilled pixels before it
scores it; :func:`inpaintenv.metrics.frame_metrics` does the same with
``unfilled="interpolate"``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["interpolate_background"]


def interpolate_background(pred: np.ndarray) -> np.ndarray:
    """Fill the unfilled (0 m, or NaN) pixels of a prediction as the KITTI devkit does.

    The devkit (``io_depth.h``, ``interpolateBackground``) runs before it scores a
    prediction. Per row, a run of unfilled pixels between two filled ones takes the
    *smaller* of the two depths (the nearer surface: the rule comes from the devkit's
    disparity code, where the smaller value is the background); runs at the row's ends
    take the nearest filled value. Then, per column, rows still empty (rows without any
    filled pixel) above the first or below the last filled row take that row's value;
    empty rows between filled ones, and frames without any filled pixel, stay 0.

    Parameters
    ----------
    pred : numpy.ndarray
        ``(H, W)`` or ``(N, H, W)`` depth in metres; ``> 0`` is filled.

    Returns
    -------
    numpy.ndarray
        float32 copy of ``pred``'s shape.
    """
    d = np.array(pred, dtype=np.float32)
    frames = d.reshape(-1, *d.shape[-2:])
    h, w = frames.shape[1:]
    rows = frames.reshape(-1, w)  # a view: filled in place
    filled = rows > 0  # NaN > 0 is False: NaN counts as unfilled
    col = np.arange(w)
    left = np.maximum.accumulate(np.where(filled, col, -1), axis=1)  # last filled at or before
    right = np.minimum.accumulate(np.where(filled, col, w)[:, ::-1], axis=1)[:, ::-1]  # next at or after
    r = np.arange(len(rows))[:, None]
    lv, rv = rows[r, np.clip(left, 0, w - 1)], rows[r, np.clip(right, 0, w - 1)]
    has_l, has_r = left >= 0, right < w
    rows[:] = np.where(
        filled, rows,
        np.where(has_l & has_r, np.minimum(lv, rv), np.where(has_l, lv, np.where(has_r, rv, 0.0))),
    )
    # Columns: after the row pass a row is entirely filled or entirely empty.
    full = frames[:, :, 0] > 0  # (N, H)
    has = full.any(axis=1)
    first = np.argmax(full, axis=1)
    last = h - 1 - np.argmax(full[:, ::-1], axis=1)
    n = np.arange(len(frames))
    y = np.arange(h)[None, :]
    source = np.where(y < first[:, None], first[:, None], np.where(y > last[:, None], last[:, None], y))
    source = np.where(has[:, None] & ~full, source, y)  # empty rows inside stay (source = itself)
    frames[:] = frames[n[:, None], source]
    return np.nan_to_num(d, nan=0.0)
