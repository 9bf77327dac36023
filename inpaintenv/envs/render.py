"""Colour-mapped panels of one frame: input, ground truth, reconstruction, error.

Used by :meth:`DepthInpaintEnv.render` and by ``inpaintenv show``. Tiles are stacked
vertically (KITTI frames are wide), each under a short label, optionally under a title
line, with a colour bar in metres under the depth tiles and under the error tile; drawn
by matplotlib on a fixed layout (:mod:`inpaintenv.report.plots`). One figure per layout (frame size,
title lines) is kept: a later panel of that layout swaps its tiles and texts and shows the colour bar
of its scale (one kept per scale), and draws the pixels a fresh figure would. Colours
and hole drawing come from :mod:`inpaintenv.report.style`, the same as the benchmark's figures:
depth in ``viridis`` reversed (near = bright) on ``[0, max_depth]``, absolute error in the
holes in ``magma`` on ``[0, error_max]``, pixels without ground truth grey, holes hatched
in the input and outlined on every tile.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

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
#: Layouts whose figure is kept; colour bars kept per layout and bar.
KEPT_LAYOUTS, KEPT_BARS = 4, 8

# One lock for the kept figures: a figure is filled and drawn by one thread at a time.
_LOCK = threading.Lock()
_PANELS: OrderedDict[tuple[int, int, int], _Panel] = OrderedDict()


@dataclass
class _Panel:
    """A kept figure: its label texts and tiles top to bottom, and per colour bar its place and the bars
    drawn so far by scale (the one of the current scale visible)."""

    fig: Any
    labels: list[Any]
    tiles: list[Any]
    bar_places: list[tuple[int, int, int]]
    bars: list[OrderedDict[float, Any]] = field(default_factory=list)


#: Rows of a tile's lookup table past the colour map's 256: no data, hatch, hole outline.
_NO_DATA, _HATCH, _EDGE = 256, 257, 258


@lru_cache(maxsize=4)
def _lut(cmap: str) -> np.ndarray:
    """``cmap``'s 256 colours then :data:`~inpaintenv.report.style.NO_DATA`, ``HATCH`` and ``HOLE_EDGE`` as opaque
    RGBA uint8, one uint32 each (a tile is then one lookup)."""
    rgb = style.to_uint8(np.vstack([style.lookup_table(cmap), [style.NO_DATA, style.HATCH, style.HOLE_EDGE]]))
    rgba = np.concatenate([rgb, np.full((len(rgb), 1), 255, np.uint8)], axis=1)
    return np.ascontiguousarray(rgba).view(np.uint32)[:, 0]


def _rgba(index: np.ndarray, cmap: str) -> np.ndarray:
    """``(H, W)`` rows of :func:`_lut` as an ``(H, W, 4)`` uint8 image."""
    return _lut(cmap)[index].view(np.uint8).reshape(*index.shape, 4)


def _index(values: np.ndarray, vmax: float, no_data: np.ndarray) -> np.ndarray:
    """Rows of :func:`_lut` colouring ``values`` (:func:`inpaintenv.report.style.depth_rgb` and ``error_rgb``)."""
    index = style.colour_indices(values, vmax).astype(np.uint16)
    index[no_data] = _NO_DATA
    return index


def _has_depth(d: np.ndarray) -> np.ndarray:
    return np.nan_to_num(d, nan=0.0) > 0


def colorize_depth(depth: np.ndarray, max_depth: float) -> np.ndarray:
    """Map ``(H, W)`` metres to RGB uint8 (:func:`inpaintenv.report.style.depth_rgb`); no data is grey."""
    d = np.asarray(depth, dtype=np.float32)
    return _rgba(_index(d, max_depth, ~_has_depth(d)), style.DEPTH_CMAP)[..., :3].copy()


def colorize_error(error: np.ndarray, valid: np.ndarray, error_max: float) -> np.ndarray:
    """Map ``(H, W)`` absolute error to RGB uint8 (:func:`inpaintenv.report.style.error_rgb`); pixels
    outside ``valid`` are grey."""
    e = np.abs(np.asarray(error, dtype=np.float32))
    return _rgba(_index(e, error_max, ~np.asarray(valid, dtype=bool)), style.ERROR_CMAP)[..., :3].copy()


def _tiles(gt: np.ndarray, hole: np.ndarray, pred: np.ndarray | None, max_depth: float,
           error_max: float | None) -> tuple[list[np.ndarray], float]:
    """The four tiles as RGBA uint8 (input hatched, ground truth, reconstruction, error; holes outlined)
    and the error scale: the pixels :mod:`inpaintenv.report.style` gives in float, coloured in one lookup each."""
    edge, stripes = style.hole_marks(hole)
    truth = _index(gt, max_depth, ~_has_depth(gt))
    inp = truth.copy()
    inp[hole] = _NO_DATA  # the input hides the holes' depth
    inp[stripes] = _HATCH
    inp[edge] = _EDGE
    truth[edge] = _EDGE
    tiles = [_rgba(inp, style.DEPTH_CMAP), _rgba(truth, style.DEPTH_CMAP)]
    if pred is None:
        black = np.zeros((*gt.shape, 4), np.uint8)
        black[..., 3] = 255
        return [*tiles, black, black], max_depth / 8.0 if error_max is None else error_max
    p = np.asarray(pred, dtype=np.float32)
    scored = hole & (gt > 0)
    abs_err = np.abs(p - gt)
    error_max = style.error_scale(abs_err[scored]) if error_max is None else error_max
    rec, err = _index(p, max_depth, ~_has_depth(p)), _index(abs_err, error_max, ~scored)
    rec[edge] = err[edge] = _EDGE
    return [*tiles, _rgba(rec, style.DEPTH_CMAP), _rgba(err, style.ERROR_CMAP)], error_max


def _layout(H: int, W: int, title_lines: int) -> list[tuple[str, int]]:
    """(kind, height) of each strip top to bottom: label, tile or colour bar."""
    parts = [("label", LABEL_HEIGHT + 2)] * title_lines
    parts += [("label", LABEL_HEIGHT), ("tile", H)] * 3 + [("bar", COLORBAR_HEIGHT)]
    return parts + [("label", LABEL_HEIGHT), ("tile", H), ("bar", COLORBAR_HEIGHT)]


def _new_panel(H: int, W: int, title_lines: int) -> _Panel:
    """The figure of a layout with empty labels, blank tiles and the places of its colour bars."""
    parts = _layout(H, W, title_lines)
    fig = plots.image_figure(W, sum(h for _, h in parts), background="black")
    panel = _Panel(fig, [], [], [])
    blank = np.zeros((H, W, 3), np.float32)
    right = max(W - 40, 8)  # room for the last tick label and the unit
    y = 0
    for kind, height in parts:
        if kind == "label":
            panel.labels.append(plots.text(fig, 4, y + height - 5, "", TEXT_POINTS, "white", ha="left", va="baseline"))
        elif kind == "tile":
            panel.tiles.append(plots.tile(fig, blank, 0, y))
        else:
            panel.bar_places.append((4, y + 3, right - 4))
            panel.bars.append(OrderedDict())
            plots.text(fig, right + 6, y + 12, "m", 6, "white", ha="left", va="baseline")
        y += height
    return panel


def _show_bar(panel: _Panel, k: int, cmap: str, vmax: float) -> None:
    """Make bar ``k`` of ``panel`` the one of ``vmax`` (drawn once per scale, the last :data:`KEPT_BARS` kept)."""
    bars = panel.bars[k]
    if vmax not in bars:
        x, y, width = panel.bar_places[k]
        plots.colourbar(panel.fig, x, y, width, cmap, vmax, None, 6, colour="white")
        bars[vmax] = panel.fig.axes[-1]
        if len(bars) > KEPT_BARS:
            bars.popitem(last=False)[1].remove()
    bars.move_to_end(vmax)
    for scale, cax in bars.items():
        cax.set_visible(scale == vmax)


def _panel(H: int, W: int, title_lines: int) -> _Panel:
    """The kept figure of a layout (made on first use; the least recently used of :data:`KEPT_LAYOUTS` dropped)."""
    key = (H, W, title_lines)
    if key not in _PANELS:
        _PANELS[key] = _new_panel(H, W, title_lines)
        if len(_PANELS) > KEPT_LAYOUTS:
            _PANELS.popitem(last=False)
    _PANELS.move_to_end(key)
    return _PANELS[key]


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
    tiles, error_max = _tiles(gt, hole, pred, max_depth, error_max)
    lines = ([title] if isinstance(title, str) else list(title)) if title else []
    labels = [*lines, "input (holes hatched)", "ground truth (holes outlined, grey = no data)",
              "reconstruction" if pred is not None else "reconstruction (none yet)",
              f"abs error in the holes, 0-{error_max:g} m"]
    with _LOCK:
        panel = _panel(*gt.shape, len(lines))
        for artist, s in zip(panel.labels, labels):
            artist.set_text(plots.plain(str(s)))
        for artist, rgba in zip(panel.tiles, tiles):
            artist.set_data(rgba)
        _show_bar(panel, 0, style.DEPTH_CMAP, max_depth)
        _show_bar(panel, 1, style.ERROR_CMAP, error_max)
        return plots.figure_pixels(panel.fig)
