"""Colour-mapped panels of one frame: input, ground truth, reconstruction, error.

Used by :meth:`DepthInpaintEnv.render` and by ``inpaintenv show``. Tiles are stacked
vertically (KITTI frames are wide), each under a short label, optionally under a title
line, with a colour bar in metres under the depth tiles and under the error tile. Colours
and hole drawing come from :mod:`inpaintenv.report.style`, the same as the benchmark's figures:
depth in ``viridis`` reversed (near = bright) on ``[0, max_depth]``, absolute error in the
holes in ``magma`` on ``[0, error_max]``, pixels without ground truth grey, holes hatched
in the input and outlined on every tile.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import cv2
import numpy as np

from ..conventions import check_max_depth
from ..report import style
from ..exceptions import InvalidInputError

__all__ = ["colorize_depth", "colorize_error", "render_panel"]

#: Height in pixels of a tile's label strip.
LABEL_HEIGHT = 18
#: Height in pixels of a colour bar (gradient and tick labels).
COLORBAR_HEIGHT = 30
_FONT = cv2.FONT_HERSHEY_SIMPLEX
_WHITE = (255, 255, 255)


def colorize_depth(depth: np.ndarray, max_depth: float) -> np.ndarray:
    """Map ``(H, W)`` metres to RGB uint8 (:func:`inpaintenv.report.style.depth_rgb`); no data is grey."""
    return style.to_uint8(style.depth_rgb(depth, max_depth))


def colorize_error(error: np.ndarray, valid: np.ndarray, error_max: float) -> np.ndarray:
    """Map ``(H, W)`` absolute error to RGB uint8 (:func:`inpaintenv.report.style.error_rgb`); pixels
    outside ``valid`` are grey."""
    return style.to_uint8(style.error_rgb(error, valid, error_max))


def _strip(text: str, width: int, height: int = LABEL_HEIGHT) -> np.ndarray:
    strip = np.zeros((height, width, 3), dtype=np.uint8)
    # A file name that is not UTF-8 reaches here as surrogate escapes, which crash OpenCV: shown as \udcXX.
    text = text.encode("utf-8", "backslashreplace").decode("utf-8")
    cv2.putText(strip, text, (4, height - 5), _FONT, 0.45, _WHITE, 1, cv2.LINE_AA)
    return strip


def _ticks(vmax: float) -> list[float]:
    """Round tick values on ``[0, vmax]``, about five of them."""
    raw = vmax / 4.0
    power = 10.0 ** math.floor(math.log10(raw))
    step = next(s * power for s in (1.0, 2.0, 2.5, 5.0, 10.0) if s * power >= raw * (1 - 1e-9))
    return [k * step for k in range(int(vmax / step + 1e-9) + 1)]


def _colorbar(cmap: str, vmax: float, width: int, unit: str = "m") -> np.ndarray:
    """A horizontal colour bar: the map's gradient over ``[0, vmax]`` with tick labels."""
    bar = np.zeros((COLORBAR_HEIGHT, width, 3), dtype=np.uint8)
    left, right = 4, max(width - 40, 8)  # room for the last label and the unit
    gradient = style.lookup_table(cmap)[np.linspace(0, 255, right - left).round().astype(np.intp)]
    bar[3:13, left:right] = style.to_uint8(gradient)[None]
    for value in _ticks(vmax):
        x = left + round(value / vmax * (right - left - 1))
        bar[13:16, x] = _WHITE
        label = f"{value:g}"
        (tw, _), _ = cv2.getTextSize(label, _FONT, 0.35, 1)
        cv2.putText(bar, label, (min(max(x - tw // 2, 0), width - tw - 1), 27), _FONT, 0.35, _WHITE, 1, cv2.LINE_AA)
    cv2.putText(bar, unit, (right + 6, 12), _FONT, 0.35, _WHITE, 1, cv2.LINE_AA)
    return bar


def render_panel(
    gt: np.ndarray,
    hole: np.ndarray,
    pred: np.ndarray | None = None,
    *,
    max_depth: float = 80.0,
    error_max: float | None = None,
    title: str | Sequence[str] | None = None,
) -> np.ndarray:
    """Render the panel of one frame as an RGB uint8 image.

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
        Top of the error colour scale in metres; by default
        :func:`inpaintenv.report.style.error_scale` of the errors in the holes (their 90th
        percentile, rounded up), so the tile uses the whole scale.
    title : str or sequence of str, optional
        Lines written above the tiles (e.g. the metrics).

    Returns
    -------
    numpy.ndarray
        ``(T + 4·(H + 18) + 2·30, W, 3)`` uint8 RGB, where ``T`` is the title height:
        input (holes hatched), ground truth, reconstruction, the depth colour bar, the
        absolute error in the holes and its colour bar.
    """
    gt = np.asarray(gt, dtype=np.float32)
    hole = np.asarray(hole).astype(bool)
    if gt.ndim != 2 or hole.shape != gt.shape:
        raise InvalidInputError(f"need (H, W) ground truth and hole of one shape, got {gt.shape} and {hole.shape}")
    if pred is not None and np.shape(pred) != gt.shape:
        raise InvalidInputError(f"reconstruction has shape {np.shape(pred)}, expected {gt.shape}")
    # A NaN or inf scale would turn every tile black without a word.
    max_depth = check_max_depth(max_depth)
    if error_max is not None:
        error_max = check_max_depth(error_max, "error_max")
    H, W = gt.shape
    scored = hole & (gt > 0)

    inp = style.draw_holes(style.depth_rgb(np.where(hole, 0.0, gt), max_depth), hole, hatch=True)
    truth = style.draw_holes(style.depth_rgb(gt, max_depth), hole)
    if pred is None:
        rec = np.zeros((H, W, 3), dtype=np.uint8)
        err = np.zeros((H, W, 3), dtype=np.uint8)
        error_max = max_depth / 8.0 if error_max is None else error_max
    else:
        p = np.asarray(pred, dtype=np.float32)
        abs_err = np.abs(p - gt)
        error_max = style.error_scale(abs_err[scored]) if error_max is None else error_max
        rec = style.to_uint8(style.draw_holes(style.depth_rgb(p, max_depth), hole))
        err = style.to_uint8(style.draw_holes(style.error_rgb(abs_err, scored, error_max), hole))

    parts: list[np.ndarray] = []
    if title:
        lines = [title] if isinstance(title, str) else list(title)
        parts.extend(_strip(line, W, LABEL_HEIGHT + 2) for line in lines)
    for label, tile in (
        ("input (holes hatched)", style.to_uint8(inp)),
        ("ground truth (holes outlined, grey = no data)", style.to_uint8(truth)),
        ("reconstruction" if pred is not None else "reconstruction (none yet)", rec),
    ):
        parts += [_strip(label, W), tile]
    parts.append(_colorbar(style.DEPTH_CMAP, max_depth, W))
    parts += [_strip(f"abs error in the holes, 0-{error_max:g} m", W), err]
    parts.append(_colorbar(style.ERROR_CMAP, error_max, W))
    return np.ascontiguousarray(np.concatenate(parts, axis=0))
