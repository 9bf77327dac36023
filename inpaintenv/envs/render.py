"""Colour-mapped panels of one frame: input, ground truth, reconstruction, error.

Used by :meth:`DepthInpaintEnv.render` and by ``inpaintenv show``. Tiles are stacked
vertically (KITTI frames are wide), each under a short label, optionally under a title
line, with a colour bar in metres under the depth tiles and under the error tile; drawn
by matplotlib on a fixed layout (:mod:`inpaintenv.report.plots`). Colours
and hole drawing come from :mod:`inpaintenv.report.style`, the same as the benchmark's figures:
depth in ``viridis`` reversed (near = bright) on ``[0, max_depth]``, absolute error in the
holes in ``magma`` on ``[0, error_max]``, pixels without ground truth grey, holes hatched
in the input and outlined on every tile.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..conventions import check_max_depth
from ..report import plots, style
from ..exceptions import InvalidInputError

__all__ = ["colorize_depth", "colorize_error", "render_panel"]

#: Height in pixels of a tile's label strip.
LABEL_HEIGHT = 18
#: Height in pixels of a colour bar (gradient and tick labels).
COLORBAR_HEIGHT = 30
#: Size of the labels' text in points (11 pixels).
TEXT_POINTS = 8


def colorize_depth(depth: np.ndarray, max_depth: float) -> np.ndarray:
    """Map ``(H, W)`` metres to RGB uint8 (:func:`inpaintenv.report.style.depth_rgb`); no data is grey."""
    return style.to_uint8(style.depth_rgb(depth, max_depth))


def colorize_error(error: np.ndarray, valid: np.ndarray, error_max: float) -> np.ndarray:
    """Map ``(H, W)`` absolute error to RGB uint8 (:func:`inpaintenv.report.style.error_rgb`); pixels
    outside ``valid`` are grey."""
    return style.to_uint8(style.error_rgb(error, valid, error_max))


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
        rec = np.zeros((H, W, 3), dtype=np.float32)
        err = np.zeros((H, W, 3), dtype=np.float32)
        error_max = max_depth / 8.0 if error_max is None else error_max
    else:
        p = np.asarray(pred, dtype=np.float32)
        abs_err = np.abs(p - gt)
        error_max = style.error_scale(abs_err[scored]) if error_max is None else error_max
        rec = style.draw_holes(style.depth_rgb(p, max_depth), hole)
        err = style.draw_holes(style.error_rgb(abs_err, scored, error_max), hole)

    # (kind, height, what): a label strip, a tile or a colour bar, top to bottom.
    parts: list[tuple[str, int, object]] = []
    if title:
        lines = [title] if isinstance(title, str) else list(title)
        parts.extend(("label", LABEL_HEIGHT + 2, line) for line in lines)
    for label, tile in (
        ("input (holes hatched)", inp),
        ("ground truth (holes outlined, grey = no data)", truth),
        ("reconstruction" if pred is not None else "reconstruction (none yet)", rec),
    ):
        parts += [("label", LABEL_HEIGHT, label), ("tile", H, tile)]
    parts.append(("bar", COLORBAR_HEIGHT, (style.DEPTH_CMAP, max_depth)))
    parts += [("label", LABEL_HEIGHT, f"abs error in the holes, 0-{error_max:g} m"), ("tile", H, err)]
    parts.append(("bar", COLORBAR_HEIGHT, (style.ERROR_CMAP, error_max)))
    fig = plots.image_figure(W, sum(h for _, h, _ in parts), background="black")
    y = 0
    for kind, height, what in parts:
        if kind == "label":
            plots.text(fig, 4, y + height - 5, str(what), TEXT_POINTS, "white", ha="left", va="baseline")
        elif kind == "tile":
            plots.tile(fig, what, 0, y)
        else:
            cmap, vmax = what
            right = max(W - 40, 8)  # room for the last tick label and the unit
            plots.colourbar(fig, 4, y + 3, right - 4, cmap, vmax, None, 6, colour="white")
            plots.text(fig, right + 6, y + 12, "m", 6, "white", ha="left", va="baseline")
        y += height
    return plots.figure_pixels(fig)
