"""Line and box plots drawn straight into an image (:mod:`.raster`): the benchmark's figures of numbers.

A plot is described first (:class:`LinePlot`, :class:`BoxPlot`: the numbers, labels and colours,
which tests read), then drawn by :func:`draw_lines` / :func:`draw_boxes`: axes with matplotlib's
tick choice (:class:`matplotlib.ticker.MaxNLocator`), a light grid, antialiased lines (OpenCV)
with round markers, matplotlib's line styles, a legend in the corner that hides the fewest points,
text in DejaVu Sans. A 640 x 460 figure takes milliseconds; a matplotlib figure took 0.1-0.3 s,
most of it laying out ticks and text.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .raster import Canvas, colour_rgb, fit_size, text_width

__all__ = ["BoxPlot", "Line", "LinePlot", "draw_boxes", "draw_lines"]

#: Dash patterns (pixels on, off, ...) of matplotlib's line styles.
DASHES: dict[str, tuple[int, ...]] = {"-": (), "--": (9, 5), ":": (2, 4), "-.": (9, 4, 2, 4)}
GRID = (230, 230, 230)
TICK_PX, LABEL_PX, TITLE_PX, LEGEND_PX = 12, 13, 13, 11


@dataclass
class Line:
    """One line of a :class:`LinePlot`: points (NaN breaks the line), label, matplotlib colour and line style."""

    label: str
    x: Sequence[float]
    y: Sequence[float]
    colour: Any
    linestyle: str = "-"


@dataclass
class LinePlot:
    """A line figure: its lines, title and axis labels; x on a base-2 log scale (``log_x``) or decreasing
    to the right (``invert_x``); ``size`` in pixels."""

    lines: list[Line]
    title: str
    xlabel: str
    ylabel: str
    log_x: bool = False
    invert_x: bool = False
    legend_columns: int = 1
    size: tuple[int, int] = (640, 460)


@dataclass
class BoxPlot:
    """Horizontal boxes (quartiles, whiskers at 1.5 IQR, outliers), one per name, top to bottom in order."""

    values: dict[str, Sequence[float]]
    colours: dict[str, Any]
    title: str
    xlabel: str
    width: int = 576
    row_height: int = 25


def _ticks(lo: float, hi: float, length: int, log2: bool = False) -> np.ndarray:
    """Tick values on ``[lo, hi]`` for an axis ``length`` pixels long: about one per 45 pixels, as matplotlib's."""
    if log2:
        return 2.0 ** np.arange(np.ceil(np.log2(lo) - 1e-9), np.floor(np.log2(hi) + 1e-9) + 1)
    from matplotlib.ticker import MaxNLocator

    t = MaxNLocator(nbins=int(np.clip(length // 45, 3, 9)), steps=[1, 2, 2.5, 5, 10]).tick_values(lo, hi)
    return t[(t >= lo - 1e-9 * abs(hi - lo)) & (t <= hi + 1e-9 * abs(hi - lo))]


def _label(t: float) -> str:
    return f"{float(t):.6g}" if abs(t) >= 1e-12 else "0"


def _limits(values: np.ndarray, log: bool = False) -> tuple[float, float]:
    """matplotlib's data limits: the finite values' range with a 5 % margin on each side."""
    v = values[np.isfinite(values) & ((values > 0) if log else True)]
    if log:
        v = np.log2(v)
    lo, hi = (float(v.min()), float(v.max())) if v.size else (0.0, 1.0)
    if hi - lo < 1e-12:
        lo, hi = lo - (0.5 if not lo else abs(lo) * 0.1), hi + (0.5 if not hi else abs(hi) * 0.1)
    pad = 0.05 * (hi - lo)
    lo, hi = lo - pad, hi + pad
    return (2.0 ** lo, 2.0 ** hi) if log else (lo, hi)


class _Axes:
    """Data -> pixel of an axes box ``(x0, y0, x1, y1)`` on the canvas."""

    def __init__(self, box: tuple[int, int, int, int], xlim: tuple[float, float], ylim: tuple[float, float],
                 log_x: bool, invert_x: bool) -> None:
        self.box, self.log_x, self.invert_x = box, log_x, invert_x
        self.xlim = tuple(np.log2(xlim)) if log_x else xlim
        self.ylim = ylim

    def px(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x0, y0, x1, y1 = self.box
        xv = np.log2(np.where(np.asarray(x, float) > 0, x, np.nan)) if self.log_x else np.asarray(x, float)
        fx = (xv - self.xlim[0]) / (self.xlim[1] - self.xlim[0])
        fx = 1 - fx if self.invert_x else fx
        fy = (np.asarray(y, float) - self.ylim[0]) / (self.ylim[1] - self.ylim[0])
        return x0 + fx * (x1 - x0), y1 - fy * (y1 - y0)


def _dashed(points: np.ndarray, pattern: tuple[int, ...]) -> list[np.ndarray]:
    """The pieces of the polyline ``points`` ((N, 2) pixels) drawn under a dash ``pattern``."""
    if not pattern:
        return [points]
    pieces, on, left, k = [], True, float(pattern[0]), 0
    current = [points[0]]
    for a, b in zip(points[:-1], points[1:]):
        seg = float(np.hypot(*(b - a)))
        pos = 0.0
        while seg - pos > left:
            pos += left
            p = a + (b - a) * (pos / seg)
            if on:
                pieces.append(np.array([*current, p]))
            current = [p]
            on, k = not on, (k + 1) % len(pattern)
            left = float(pattern[k])
        left -= seg - pos
        current.append(b)
    if on and len(current) > 1:
        pieces.append(np.array(current))
    return pieces


def _polyline(pixels: np.ndarray, points: np.ndarray, colour: tuple[int, int, int], style: str, width: int = 2) -> None:
    import cv2

    for piece in _dashed(points, DASHES.get(style, ())):
        cv2.polylines(pixels, [np.round(piece * 16).astype(np.int32)], False, colour, width, cv2.LINE_AA, shift=4)


def _marker(pixels: np.ndarray, x: float, y: float, colour: tuple[int, int, int], radius: int = 4) -> None:
    import cv2

    cv2.circle(pixels, (int(round(x * 16)), int(round(y * 16))), radius * 16, colour, -1, cv2.LINE_AA, shift=4)


def _frame(canvas_px: np.ndarray, box: tuple[int, int, int, int]) -> None:
    import cv2

    cv2.rectangle(canvas_px, box[:2], box[2:], (0, 0, 0), 1)


def _legend_box(plot: LinePlot, axes: _Axes, points: np.ndarray) -> tuple[int, int, int, int, int, int] | None:
    """``(x, y, width, height, rows, column width)`` of the legend in the corner of the axes that hides the fewest points."""
    if not plot.lines:
        return None
    cols = max(1, plot.legend_columns)
    rows = -(-len(plot.lines) // cols)
    col_w = 34 + max(text_width(ln.label, LEGEND_PX) for ln in plot.lines) + 8
    w, h = cols * col_w + 6, rows * (LEGEND_PX + 6) + 8
    x0, y0, x1, y1 = axes.box
    corners = [(x1 - w - 6, y0 + 6), (x0 + 6, y0 + 6), (x0 + 6, y1 - h - 6), (x1 - w - 6, y1 - h - 6)]

    def hidden(c: tuple[int, int]) -> int:
        inside = (points[:, 0] >= c[0]) & (points[:, 0] <= c[0] + w) & (points[:, 1] >= c[1]) & (points[:, 1] <= c[1] + h)
        return int(inside.sum())

    x, y = min(corners, key=hidden)  # the first of the fewest, upper right first, as matplotlib's "best"
    return x, y, w, h, rows, col_w


def _title(canvas: Canvas, text: str, centre: float, width: int) -> None:
    """The title over the axes centred at ``centre``, moved and shrunk as needed to stay inside the figure."""
    px = fit_size(text, width - 8, TITLE_PX)
    half = text_width(text, px) / 2
    canvas.text(min(max(centre, half + 4), width - half - 4), 8, text, px)


def draw_lines(plot: LinePlot) -> Canvas:
    """The figure of ``plot`` on a canvas of ``plot.size`` pixels."""
    width, height = plot.size
    xs = np.concatenate([np.asarray(ln.x, float) for ln in plot.lines] or [np.empty(0)])
    ys = np.concatenate([np.asarray(ln.y, float) for ln in plot.lines] or [np.empty(0)])
    drawn = np.isfinite(xs) & np.isfinite(ys) & ((xs > 0) if plot.log_x else True)  # NaN hides a point
    xs, ys = xs[drawn], ys[drawn]
    xlim, ylim = _limits(xs, plot.log_x), _limits(ys)
    xticks, yticks = _ticks(*xlim, width - 100, log2=plot.log_x), _ticks(*ylim, height - 80)
    left = 8 + LABEL_PX + 8 + max((text_width(_label(t), TICK_PX) for t in yticks), default=0) + 8
    top = 8 + (TITLE_PX + 3) * (plot.title.count("\n") + 1) + 6
    box = (left, top, width - 16, height - (8 + LABEL_PX + 8 + TICK_PX + 10))
    axes = _Axes(box, xlim, ylim, plot.log_x, plot.invert_x)
    px = np.full((height, width, 3), 255, np.uint8)
    import cv2

    tx, _ = axes.px(xticks, np.zeros(len(xticks)))
    _, ty = axes.px(np.ones(len(yticks)), yticks)
    for x in tx:
        cv2.line(px, (int(round(x)), box[1]), (int(round(x)), box[3]), GRID, 1)
        cv2.line(px, (int(round(x)), box[3]), (int(round(x)), box[3] + 4), (0, 0, 0), 1)
    for y in ty:
        cv2.line(px, (box[0], int(round(y))), (box[2], int(round(y))), GRID, 1)
        cv2.line(px, (box[0] - 4, int(round(y))), (box[0], int(round(y))), (0, 0, 0), 1)
    shown = []
    for ln in plot.lines:
        lx, ly = axes.px(np.asarray(ln.x, float), np.asarray(ln.y, float))
        ok = np.isfinite(lx) & np.isfinite(ly)
        colour = colour_rgb(ln.colour)
        runs = np.split(np.arange(len(ok)), np.flatnonzero(np.diff(ok.astype(int))) + 1)
        for run in runs:  # a NaN breaks the line, as in matplotlib
            if len(run) > 1 and ok[run[0]]:
                _polyline(px, np.stack([lx[run], ly[run]], 1), colour, ln.linestyle)
        for x, y in zip(lx[ok], ly[ok]):
            _marker(px, x, y, colour)
        shown.append(np.stack([lx[ok], ly[ok]], 1))
    _frame(px, box)
    legend = _legend_box(plot, axes, np.concatenate(shown or [np.empty((0, 2))]))
    if legend is not None:
        x, y, w, h, rows, col_w = legend
        cv2.rectangle(px, (x, y), (x + w, y + h), (255, 255, 255), -1)
        cv2.rectangle(px, (x, y), (x + w, y + h), (204, 204, 204), 1)
        for k, ln in enumerate(plot.lines):
            cx, cy = x + 6 + (k // rows) * col_w, y + 4 + (k % rows) * (LEGEND_PX + 6) + (LEGEND_PX + 6) / 2
            _polyline(px, np.array([[cx, cy], [cx + 26, cy]], float), colour_rgb(ln.colour), ln.linestyle)
            _marker(px, cx + 13, cy, colour_rgb(ln.colour))
    canvas = Canvas.of(px)
    for x, t in zip(tx, xticks):
        canvas.text(x, box[3] + 6, _label(t), TICK_PX)
    for y, t in zip(ty, yticks):
        canvas.text(box[0] - 7, y, _label(t), TICK_PX, anchor="rm")
    _title(canvas, plot.title, (box[0] + box[2]) / 2, width)
    canvas.text((box[0] + box[2]) / 2, height - 8, plot.xlabel, LABEL_PX, anchor="md")
    canvas.vertical_text(8, (box[1] + box[3]) / 2, plot.ylabel, LABEL_PX)
    if legend is not None:
        x, y, w, h, rows, col_w = legend
        for k, ln in enumerate(plot.lines):
            cx, cy = x + 6 + (k // rows) * col_w, y + 4 + (k % rows) * (LEGEND_PX + 6) + (LEGEND_PX + 6) / 2
            canvas.text(cx + 34, cy, ln.label, LEGEND_PX, anchor="lm")
    return canvas


def draw_boxes(plot: BoxPlot) -> Canvas:
    """The figure of ``plot``: one horizontal box per name, the first at the top."""
    from matplotlib.cbook import boxplot_stats

    names = list(plot.values)
    stats = [boxplot_stats(np.asarray(plot.values[n], float))[0] for n in names]
    every = np.concatenate([np.asarray(plot.values[n], float) for n in names] or [np.empty(0)])
    xlim = _limits(every)
    ticks = _ticks(*xlim, plot.width - 100)
    left = 8 + max((text_width(n, TICK_PX - 1) for n in names), default=0) + 10
    top = 8 + TITLE_PX + 9
    height = top + plot.row_height * max(len(names), 1) + 8 + TICK_PX + 8 + LABEL_PX + 10
    box = (left, top, plot.width - 16, top + plot.row_height * max(len(names), 1))
    axes = _Axes(box, xlim, (len(names) + 0.5, 0.5), False, False)
    px = np.full((height, plot.width, 3), 255, np.uint8)
    import cv2

    tx, _ = axes.px(ticks, np.zeros(len(ticks)))
    for x in tx:
        cv2.line(px, (int(round(x)), box[1]), (int(round(x)), box[3]), GRID, 1)
        cv2.line(px, (int(round(x)), box[3]), (int(round(x)), box[3] + 4), (0, 0, 0), 1)
    half = 0.3  # boxes 0.6 of a row high
    for k, (name, s) in enumerate(zip(names, stats)):
        q1, q3, med, lo, hi = axes.px(np.array([s["q1"], s["q3"], s["med"], s["whislo"], s["whishi"]]), np.zeros(5))[0]
        ya, yb, yc = axes.px(np.zeros(3), np.array([k + 1 - half, k + 1 + half, k + 1]))[1]
        fill = np.round(255 - 0.55 * (255 - np.array(colour_rgb(plot.colours.get(name, "grey"))))).astype(int).tolist()
        p = lambda v: int(round(v))  # noqa: E731 - pixel of a coordinate
        cv2.rectangle(px, (p(q1), p(yb)), (p(q3), p(ya)), fill, -1)
        cv2.rectangle(px, (p(q1), p(yb)), (p(q3), p(ya)), (0, 0, 0), 1)
        cv2.line(px, (p(med), p(yb)), (p(med), p(ya)), (0, 0, 0), 2)
        for end, edge in ((lo, q1), (hi, q3)):
            cv2.line(px, (p(end), p(yc)), (p(edge), p(yc)), (0, 0, 0), 1)
            cv2.line(px, (p(end), p((yc + ya) / 2)), (p(end), p((yc + yb) / 2)), (0, 0, 0), 1)
        fx, _ = axes.px(np.asarray(s["fliers"], float), np.zeros(len(s["fliers"])))
        for x in fx:
            cv2.circle(px, (int(round(x * 16)), int(round(yc * 16))), 3 * 16, (0, 0, 0), 1, cv2.LINE_AA, shift=4)
    _frame(px, box)
    canvas = Canvas.of(px)
    for x, t in zip(tx, ticks):
        canvas.text(x, box[3] + 6, _label(t), TICK_PX)
    for k, name in enumerate(names):
        canvas.text(box[0] - 6, axes.px(np.zeros(1), np.array([k + 1.0]))[1][0], name, TICK_PX - 1, anchor="rm")
    _title(canvas, plot.title, (box[0] + box[2]) / 2, plot.width)
    canvas.text((box[0] + box[2]) / 2, height - 8, plot.xlabel, LABEL_PX, anchor="md")
    return canvas

