"""Colour-mapped panels of one frame: input, hole, ground truth, reconstruction, error.

Used by :meth:`DepthInpaintEnv.render` and by ``inpaintenv show``. Tiles are stacked
vertically (KITTI frames are wide), each under a short label, optionally under a title
line. Depth uses OpenCV's TURBO colormap on ``[0, max_depth]``; absolute error uses
INFERNO on ``[0, error_max]``; pixels without ground truth (0) stay black.
"""

from __future__ import annotations

from collections.abc import Sequence

import cv2
import numpy as np

from ..conventions import check_max_depth

__all__ = ["colorize_depth", "colorize_error", "render_panel"]

#: Height in pixels of a tile's label strip.
LABEL_HEIGHT = 18
_FONT = cv2.FONT_HERSHEY_SIMPLEX
#: Grey drawn for the occluded pixels in the input tile (distinct from "no data" black).
HOLE_GREY = (90, 90, 90)


def _colormap(name: str, fallback: int) -> int:
    return int(getattr(cv2, name, fallback))


def colorize_depth(depth: np.ndarray, max_depth: float) -> np.ndarray:
    """Map ``(H, W)`` metres to RGB uint8 with TURBO; 0 (no data) and NaN become black."""
    d = np.nan_to_num(np.asarray(depth, dtype=np.float32), nan=0.0)
    scaled = np.clip(d / max_depth * 255.0, 0, 255).astype(np.uint8)
    bgr = cv2.applyColorMap(scaled, _colormap("COLORMAP_TURBO", cv2.COLORMAP_JET))
    bgr[d <= 0] = 0
    return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)


def colorize_error(error: np.ndarray, valid: np.ndarray, error_max: float) -> np.ndarray:
    """Map ``(H, W)`` absolute error to RGB uint8 with INFERNO; pixels outside ``valid`` black."""
    e = np.nan_to_num(np.asarray(error, dtype=np.float32), nan=0.0)
    scaled = np.clip(e / error_max * 255.0, 0, 255).astype(np.uint8)
    bgr = cv2.applyColorMap(scaled, _colormap("COLORMAP_INFERNO", cv2.COLORMAP_HOT))
    bgr[~valid] = 0
    return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)


def _strip(text: str, width: int, height: int = LABEL_HEIGHT) -> np.ndarray:
    strip = np.zeros((height, width, 3), dtype=np.uint8)
    cv2.putText(strip, text, (4, height - 5), _FONT, 0.45, (255, 255, 255), 1, cv2.LINE_AA)
    return strip


def render_panel(
    gt: np.ndarray,
    hole: np.ndarray,
    pred: np.ndarray | None = None,
    *,
    max_depth: float = 80.0,
    error_max: float | None = None,
    title: str | Sequence[str] | None = None,
) -> np.ndarray:
    """Render the five-tile panel of one frame as an RGB uint8 image.

    Parameters
    ----------
    gt : numpy.ndarray
        ``(H, W)`` ground truth in metres, 0 = no measurement.
    hole : numpy.ndarray
        ``(H, W)`` bool (or 0/1) occlusion mask.
    pred : numpy.ndarray, optional
        ``(H, W)`` reconstruction; its tile and the error tile stay black without it.
    max_depth : float
        Top of the depth colour scale in metres.
    error_max : float, optional
        Top of the error colour scale in metres; ``max_depth / 8`` by default (10 m).
    title : str or sequence of str, optional
        Lines written above the tiles (e.g. the metrics).

    Returns
    -------
    numpy.ndarray
        ``(T + 5·(H + 18), W, 3)`` uint8 RGB, where ``T`` is the title height.
    """
    gt = np.asarray(gt, dtype=np.float32)
    hole = np.asarray(hole).astype(bool)
    if gt.ndim != 2 or hole.shape != gt.shape:
        raise ValueError(f"need (H, W) ground truth and hole of one shape, got {gt.shape} and {hole.shape}")
    if pred is not None and np.shape(pred) != gt.shape:
        raise ValueError(f"reconstruction has shape {np.shape(pred)}, expected {gt.shape}")
    # A NaN or inf scale would turn every tile black without a word.
    max_depth = check_max_depth(max_depth)
    error_max = max_depth / 8.0 if error_max is None else check_max_depth(error_max, "error_max")
    H, W = gt.shape
    valid = gt > 0

    inp = colorize_depth(np.where(hole, 0.0, gt), max_depth)
    inp[hole] = HOLE_GREY
    hole_tile = np.zeros((H, W, 3), dtype=np.uint8)
    hole_tile[hole] = (255, 255, 255)
    hole_tile[hole & valid] = (255, 60, 60)  # the pixels that are scored
    truth = colorize_depth(gt, max_depth)
    if pred is None:
        rec = np.zeros((H, W, 3), dtype=np.uint8)
        err = np.zeros((H, W, 3), dtype=np.uint8)
    else:
        p = np.asarray(pred, dtype=np.float32)
        rec = colorize_depth(p, max_depth)
        err = colorize_error(np.abs(p - gt), valid, error_max)

    tiles = [
        ("input (holes grey)", inp),
        ("hole (red = scored)", hole_tile),
        ("ground truth", truth),
        ("reconstruction" if pred is not None else "reconstruction (none yet)", rec),
        (f"abs error, 0-{error_max:g} m", err),
    ]
    parts: list[np.ndarray] = []
    if title:
        lines = [title] if isinstance(title, str) else list(title)
        parts.extend(_strip(line, W, LABEL_HEIGHT + 2) for line in lines)
    for label, tile in tiles:
        parts.append(_strip(label, W))
        parts.append(tile)
    return np.ascontiguousarray(np.concatenate(parts, axis=0))
