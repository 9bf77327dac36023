"""The benchmark's figures, drawn by matplotlib (Agg, bare :class:`~matplotlib.figure.Figure` objects).

Line plots (:func:`line_figure`), horizontal box plots (:func:`box_figure`) and figures of image
tiles (:func:`image_figure`, :func:`tile`, :func:`text`, :func:`colourbar`). Every layout is fixed
in pixels (no ``tight_layout``), tiles arrive already sampled and coloured at their shown size
(:mod:`.raster`, :mod:`.style`) and are placed pixel for pixel (drawn as they are: nothing resampled),
and a figure is drawn once and encoded by :func:`figure_png`. Line plots of one size share one
figure (its axes and ticks are kept; the lines, legend and texts replaced): encode it before
drawing the next. Text is never read as mathtext (a ``$`` in a name stays a ``$``).
"""

from __future__ import annotations

import threading
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np

from . import style
from .raster import png_bytes

__all__ = [
    "DPI", "Line", "box_figure", "colourbar", "figure_pixels", "figure_png", "image_figure", "line_figure", "text", "tile",
]

#: Dots per inch of every figure here: 1 pt of text is 100/72 pixels.
DPI = 100
#: Size (pixels) of a line plot.
LINE_SIZE = (640, 460)
#: Axes of a line plot as (left, bottom, right, top) margins in pixels.
LINE_MARGINS = (70, 48, 16, 30)
TICK_PT, LABEL_PT, TITLE_PT, LEGEND_PT = 8, 9, 9, 7
#: Settings every figure here is drawn under: glyphs without FreeType's hinting (text set a third faster).
DRAW_RC = {"text.hinting": "no_hinting"}
_LOCK = threading.Lock()
_SHARED: dict[tuple[int, int], Any] = {}


@dataclass
class Line:
    """One line of a :func:`line_figure`: points (NaN breaks the line), label, matplotlib colour and line style."""

    label: str
    x: Sequence[float]
    y: Sequence[float]
    colour: Any
    linestyle: str = "-"


def plain(s: str) -> str:
    """``s`` as matplotlib should set it: never mathtext (``$`` escaped), a name that is not UTF-8
    (surrogate escapes, as Python reads it) shown as ``\\udcXX``."""
    return s.encode("utf-8", "backslashreplace").decode("utf-8").replace("$", r"\$")


def new_figure(width: int, height: int) -> Any:
    """A white figure of ``width`` x ``height`` pixels on an Agg canvas (no pyplot state)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    # A hair over the size: Agg truncates the size in pixels, and W / DPI * DPI may fall just short of W.
    fig = Figure(figsize=((width + 0.01) / DPI, (height + 0.01) / DPI), dpi=DPI, facecolor="white")
    FigureCanvasAgg(fig)
    return fig


def _draw(fig: Any) -> np.ndarray:
    """``fig`` drawn once by Agg under :data:`DRAW_RC`: its RGBA pixels."""
    import matplotlib

    with matplotlib.rc_context(DRAW_RC):
        fig.canvas.draw()
    return np.asarray(fig.canvas.buffer_rgba())


def figure_png(fig: Any) -> bytes:
    """``fig`` drawn once by Agg, as PNG bytes (:func:`.raster.png_bytes`: zlib's fastest level)."""
    return png_bytes(_draw(fig))


@lru_cache(maxsize=1)
def _measurer() -> Any:
    from matplotlib.backends.backend_agg import RendererAgg

    return RendererAgg(1, 1, DPI)


@lru_cache(maxsize=512)
def text_width(s: str, points: float) -> float:
    """Width in pixels of ``s`` (its widest line) set by matplotlib at ``points`` on a figure of :data:`DPI`."""
    from matplotlib.font_manager import FontProperties

    prop = FontProperties(size=points)  # default hinting: 1-3 % wider than drawn, so what fits here fits
    return max(_measurer().get_text_width_height_descent(line, prop, ismath=False)[0] for line in s.split("\n"))


def fit_points(s: str, width: float, points: float, smallest: float = 5.0) -> float:
    """The largest size from ``points`` down to ``smallest`` (half-point steps) at which ``s`` fits ``width`` pixels."""
    while points > smallest and text_width(plain(s), points) > width:
        points -= 0.5
    return points


def text(fig: Any, x: float, y: float, s: str, points: float, colour: Any = "black", *, ha: str = "center",
         va: str = "top", fit: float | None = None) -> Any:
    """Set ``s`` at pixel ``(x, y)`` from the top-left of ``fig``; lines split at ``\\n`` and centred.
    With ``fit``, shrunk to fit that many pixels."""
    width, height = fig.bbox.width, fig.bbox.height
    if fit is not None:
        points = fit_points(s, fit, points)
    return fig.text(x / width, 1 - y / height, plain(s), fontsize=points, color=colour, ha=ha, va=va,
                    multialignment="center", linespacing=1.25)


@lru_cache(maxsize=1)
def _pixels_artist() -> type:
    from matplotlib.artist import Artist

    class Pixels(Artist):
        """RGBA uint8 pixels drawn by the renderer as they are, bottom-left corner at canvas pixel ``(x, y)``
        (``figimage`` resamples and masks every image first: 20 ms a KITTI frame, for the same pixels)."""

        zorder = 1

        def __init__(self, rgba: np.ndarray, x: int, y: int) -> None:
            super().__init__()
            self.rgba, self.x, self.y = rgba, x, y

        def set_data(self, rgba: np.ndarray) -> None:
            self.rgba = rgba
            self.stale = True

        def draw(self, renderer: Any) -> None:
            if self.get_visible():
                gc = renderer.new_gc()
                renderer.draw_image(gc, self.x, self.y, self.rgba[::-1])  # Agg takes the bottom row first
                gc.restore()

    return Pixels


def tile(fig: Any, rgb: np.ndarray, x: int, y: int) -> Any:
    """Place a float RGB image in ``[0, 1]`` (:mod:`.style`'s) or a uint8 RGBA image with its top-left corner at
    pixel ``(x, y)``, pixel for pixel.

    Returns its artist: ``set_data`` swaps in another image of its size.
    """
    if np.shape(rgb)[-1] == 4 and np.asarray(rgb).dtype == np.uint8:
        img = np.asarray(rgb)
    else:
        img = np.empty((*np.shape(rgb)[:2], 4), np.uint8)  # RGBA: Agg takes it without a conversion
        img[..., :3] = style.to_uint8(rgb)
        img[..., 3] = 255
    artist = _pixels_artist()(img, int(x), int(round(fig.bbox.height)) - int(y) - img.shape[0])
    fig.add_artist(artist)
    return artist


def colourbar(fig: Any, x: int, y: int, width: int, cmap: str, vmax: float, label: str | None, points: float = 8,
              colour: Any = "black") -> int:
    """A horizontal colour bar of ``cmap`` on ``[0, vmax]`` at pixel ``(x, y)``, ticks and ``label`` below, in
    ``colour`` (white on a dark figure).

    Returns the height it takes (pixels).
    """
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    bar = 12 if label is not None else 10
    fw, fh = fig.bbox.width, fig.bbox.height
    cax = fig.add_axes((x / fw, 1 - (y + bar) / fh, width / fw, bar / fh))
    cb = fig.colorbar(ScalarMappable(norm=Normalize(0.0, vmax), cmap=cmap), cax=cax, orientation="horizontal")
    cb.ax.tick_params(labelsize=points, length=3, pad=1, colors=colour)
    cb.outline.set_visible(label is not None)  # without a label (a dark panel's bar): the colours to its edge
    if label is not None:
        cb.set_label(plain(label), fontsize=points, labelpad=1, color=colour)
    return bar + 10 + (2 if label is not None else 1) * int(np.ceil(points * DPI / 72))


def image_figure(width: int, height: int, background: Any = "white") -> Any:
    """A figure for tiles, text and colour bars placed in pixels (:func:`tile`, :func:`text`, :func:`colourbar`)."""
    fig = new_figure(width, height)
    fig.set_facecolor(background)
    return fig


def figure_pixels(fig: Any) -> np.ndarray:
    """``fig`` drawn once by Agg, as an ``(H, W, 3)`` uint8 RGB array."""
    return np.array(_draw(fig)[..., :3])


def _shared_axes(size: tuple[int, int]) -> tuple[Any, Any]:
    """The line plots' figure of ``size`` and its axes, emptied: lines, legend and texts removed, scales reset."""
    if size not in _SHARED:
        fig = new_figure(*size)
        left, bottom, right, top = LINE_MARGINS
        ax = fig.add_axes((left / size[0], bottom / size[1], 1 - (left + right) / size[0], 1 - (bottom + top) / size[1]))
        ax.tick_params(labelsize=TICK_PT)
        # Fixed label places: matplotlib would otherwise measure every tick label to move them.
        ax.xaxis.set_label_coords(0.5, -34 / (size[1] - bottom - top))
        ax.yaxis.set_label_coords(-(left - 14) / (size[0] - left - right), 0.5)
        _SHARED[size] = fig, ax
    fig, ax = _SHARED[size]
    for artist in [*ax.lines, *fig.texts]:
        artist.remove()
    if ax.get_legend() is not None:
        ax.get_legend().remove()
    ax.set_xscale("linear")
    ax.xaxis.set_inverted(False)
    ax.set_autoscale_on(True)
    return fig, ax


def _corner(ax: Any, lines: Sequence[Line], columns: int) -> str:
    """The corner of ``ax`` whose legend-sized box holds the fewest points of ``lines`` (upper right first on a
    tie): matplotlib's ``loc="best"`` among the corners, without measuring the legend at draw time."""
    points = np.concatenate([np.stack([np.asarray(ln.x, float), np.asarray(ln.y, float)], 1) for ln in lines
                             if len(ln.x)] or [np.empty((0, 2))])
    with np.errstate(all="ignore"):  # x <= 0 on a log axis: no place, no point
        fx, fy = (ax.transScale + ax.transLimits).transform(points).T if len(points) else np.empty((2, 0))
    rows = -(-len(lines) // max(1, columns))
    w = min(0.9, 0.12 + max(text_width(plain(ln.label), LEGEND_PT) for ln in lines) * columns / ax.bbox.width)
    h = min(0.9, (rows * 13 + 12) / ax.bbox.height)
    boxes = {"upper right": (1 - w, 1 - h), "upper left": (0, 1 - h), "lower left": (0, 0), "lower right": (1 - w, 0)}
    hidden = {loc: int(((fx >= x) & (fx <= x + w) & (fy >= y) & (fy <= y + h)).sum()) for loc, (x, y) in boxes.items()}
    return min(boxes, key=lambda loc: hidden[loc])


def line_figure(
    lines: Sequence[Line], title: str, xlabel: str, ylabel: str, *, log_x: bool = False, invert_x: bool = False,
    legend_columns: int = 1, size: tuple[int, int] = LINE_SIZE,
) -> Any:
    """A figure of ``lines`` (round markers; a NaN breaks a line), x on a base-2 log scale (``log_x``: points at
    x <= 0 left out) or decreasing to the right (``invert_x``), the legend where it hides the fewest points.

    The figure is shared by every line plot of ``size``: encode it (:func:`figure_png`) before the next call.
    """
    with _LOCK:
        fig, ax = _shared_axes(size)
        for ln in lines:
            x, y = np.asarray(ln.x, float), np.asarray(ln.y, float)
            if log_x:
                y = np.where(x > 0, y, np.nan)
                x = np.where(x > 0, x, np.nan)
            ax.plot(x, y, marker="o", markersize=4, color=ln.colour, linestyle=ln.linestyle, label=plain(ln.label))
        if log_x:  # ticks at powers of 2 written as plain numbers (mathtext 2^k is slow to set)
            from matplotlib.ticker import FuncFormatter

            ax.set_xscale("log", base=2)
            ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
            ax.minorticks_off()
        ax.relim()
        ax.autoscale_view()
        ax.xaxis.set_inverted(invert_x)
        ax.set_xlabel(plain(xlabel), fontsize=LABEL_PT)
        ax.set_ylabel(plain(ylabel), fontsize=LABEL_PT)
        ax.grid(True, alpha=0.3)
        if lines:
            ax.legend(fontsize=LEGEND_PT, ncol=max(1, legend_columns), loc=_corner(ax, lines, legend_columns))
        left, _, right, top = LINE_MARGINS
        text(fig, (left + size[0] - right) / 2, 8, title, TITLE_PT, fit=size[0] - 8)
        return fig


def box_figure(values: dict[str, Sequence[float]], colours: dict[str, Any], title: str, xlabel: str, *,
               width: int = 576, row_height: int = 25) -> Any:
    """Horizontal boxes (quartiles, whiskers at 1.5 IQR, outliers), one per name of ``values``, the first at the
    top, each filled in its colour of ``colours``."""
    names = list(values)
    rows = max(len(names), 1)
    top, bottom = 30, 48
    height = top + row_height * rows + bottom
    fig = new_figure(width, height)
    left = 14 + max((text_width(plain(n), TICK_PT) for n in names), default=0)
    left = min(left, width // 2)
    ax = fig.add_axes((left / width, bottom / height, 1 - (left + 16) / width, row_height * rows / height))
    if names:
        parts = ax.boxplot([np.asarray(values[n], float) for n in names], orientation="horizontal", widths=0.6,
                           patch_artist=True, showfliers=True, medianprops={"color": "black"})
        for patch, name in zip(parts["boxes"], names):
            patch.set_facecolor(colours.get(name, "grey"))
            patch.set_alpha(0.55)
        ax.set_yticks(range(1, len(names) + 1), [plain(n) for n in names])
    ax.set_ylim(rows + 0.5, 0.5)
    ax.tick_params(labelsize=TICK_PT)
    ax.set_xlabel(plain(xlabel), fontsize=LABEL_PT)
    ax.grid(True, alpha=0.3, axis="x")
    text(fig, width / 2, 8, title, TITLE_PT, fit=width - 8)
    return fig
