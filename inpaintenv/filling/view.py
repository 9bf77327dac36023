"""The pixels a LiDAR scan could have measured: its vertical field of view in the image, from the scan itself.

A scan projected into a camera covers a band of the image: above the top beam is sky no beam
reaches, and below the bottom beam nothing is seen either. ``fill --missing`` densifies only
inside that band (``--fill-all``: every pixel). Per image column the band runs from the
topmost to the bottommost measured row, each taken as the extreme over the neighbouring
columns (a column whose top beam found nothing to return from, e.g. sky between two trees,
gets its neighbours' edge); columns with no measurement near them take the edge of the
nearest columns that have one. NumPy only: no calibration, no torch.
"""

from __future__ import annotations

import numpy as np

__all__ = ["VIEW_WINDOW", "sensor_view"]

#: Half-width of the column window, as a fraction of the image width (at least 8 columns):
#: about 1.8 degrees of a KITTI camera's 82 degree field of view.
VIEW_WINDOW = 1 / 48


def _envelope(edge: np.ndarray, half: int, upper: bool) -> np.ndarray:
    """``edge`` (per column; inf where unknown) as the extreme over ``±half`` columns, gaps interpolated."""
    padded = np.pad(edge, half, constant_values=np.inf if upper else -np.inf)
    windows = np.lib.stride_tricks.sliding_window_view(padded, 2 * half + 1)
    out = windows.min(axis=1) if upper else windows.max(axis=1)
    known = np.isfinite(out)
    if not known.all():
        cols = np.arange(len(out))
        out = np.interp(cols, cols[known], out[known])
    return out


def sensor_view(depth: np.ndarray, window: float = VIEW_WINDOW) -> np.ndarray:
    """The pixels inside the vertical extent of ``depth``'s measurements, column by column.

    Parameters
    ----------
    depth : numpy.ndarray
        ``(H, W)`` depth map of one scan (metres; 0 or NaN = no measurement).
    window : float
        Half-width of the column window as a fraction of ``W`` (at least 8 columns).

    Returns
    -------
    numpy.ndarray of bool
        ``(H, W)``: True between the band's top and bottom rows (both included); all False
        when nothing is measured.

    Examples
    --------
    >>> d = np.zeros((6, 20), np.float32)
    >>> d[2, :] = 5.0
    >>> d[4, 3] = 3.0
    >>> sensor_view(d)[:, 0].astype(int).tolist()
    [0, 0, 1, 1, 1, 0]
    """
    depth = np.asarray(depth)
    measured = depth > 0  # NaN compares False
    height, width = measured.shape
    has = measured.any(axis=0)
    if not has.any():
        return np.zeros(measured.shape, bool)
    top = np.where(has, measured.argmax(axis=0), np.inf)
    bottom = np.where(has, height - 1 - measured[::-1].argmax(axis=0), -np.inf)
    half = max(8, int(round(window * width)))
    top_edge = np.ceil(_envelope(top, half, upper=True) - 1e-9)
    bottom_edge = np.floor(_envelope(bottom, half, upper=False) + 1e-9)
    rows = np.arange(height)[:, None]
    return (rows >= top_edge[None, :]) & (rows <= bottom_edge[None, :])
