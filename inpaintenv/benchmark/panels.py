"""The frame panels of a benchmark task: the study's Fig. 2 for one frame, one matplotlib figure.

Each tile is sampled to its shown size first (:data:`TILE_WIDTH` pixels wide, nearest pixel, as
matplotlib's ``interpolation="nearest"`` shows it), coloured there in the look of
:mod:`inpaintenv.report.style`, and placed pixel for pixel with its title and the colour bars on a
fixed layout (:mod:`inpaintenv.report.plots`): no axes per tile, nothing resampled at draw time.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..data.base import DepthDataset
from ..data.inputs import INPUTS
from ..metrics import frame_metrics
from ..report import style
from ..report.plots import colourbar, figure_png, image_figure, text, tile
from ..report.raster import sample_grid
from .figure_io import save_png
from .figures import FramePredictions

__all__ = ["TILE_WIDTH", "PanelTiles", "draw_panel", "frame_panel", "panel_tiles"]

#: Shown width of a tile (pixels): a KITTI frame (1216-1242 px wide) at about 1/3.3, as the panels always showed it.
TILE_WIDTH = 380


@dataclass
class PanelTiles:
    """What a frame panel shows: per method a row of ``(image, title, title colour)`` tiles, and the colour bars.

    Images are float RGB in ``[0, 1]`` at the shown size; each bar is ``(first column, columns spanned,
    colour map, top of the scale, label)``.
    """

    title: str
    rows: list[list[tuple[np.ndarray, str, Any]]]
    bars: list[tuple[int, int, str, float, str]] = field(default_factory=list)


def _scores(predictions: FramePredictions, name: str, index: int, pred: np.ndarray, max_depth: float) -> str:
    """The title of a fill tile: the method and its task and all-pixel scores on the frame."""
    gt, hole = predictions.frame(index)
    scan = None if INPUTS[predictions.input_kind].is_map else predictions.inputs(index)
    m = frame_metrics(pred, gt, hole, max_depth=max_depth, unfilled=predictions.policy(name), inputs=scan)
    if predictions.protocol.task == "unmeasured":
        return f"{name}\nunmeasured RMSE {float(m['unmeasured_rmse']):.2f} m | all {float(m['all_rmse']):.2f} m"
    return (f"{name}\nhole RMSE {float(m['hole_rmse']):.2f} m, PSNR {float(m['hole_psnr']):.1f} dB | "
            f"all {float(m['all_rmse']):.2f} m, {float(m['all_psnr']):.1f} dB")


def _shown_input(x: np.ndarray, width: int) -> np.ndarray:
    """The method's input as drawn: a scan's points widened to ``width`` pixels (the max depth of each
    neighbourhood), so points stay visible in a shrunk tile; NaN shown as no data."""
    shown = np.nan_to_num(x, nan=0.0)
    if width > 1:
        import cv2

        shown = cv2.dilate(shown.astype(np.float32), np.ones((width, width), np.uint8))
    return shown


def _shown_hole(hole: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """The hole at the shown size: a shown pixel is in the hole when any frame pixel it covers is, so a
    hole thinner than the shrink factor still shows."""
    if len(cols) >= hole.shape[1]:
        return hole[rows][:, cols]
    import cv2

    return cv2.resize(hole.astype(np.float32), (len(cols), len(rows)), interpolation=cv2.INTER_AREA) > 0


def panel_tiles(
    predictions: FramePredictions, index: int, names: Sequence[str], *, max_depth: float = 80.0,
    colours: Mapping[str, Any] | None = None, width: int = TILE_WIDTH,
) -> PanelTiles:
    """The tiles of frame ``index``'s panel for the methods ``names`` (see :func:`frame_panel`)."""
    colours = colours or style.method_colours(names)
    gt, hole = predictions.frame(index)
    scored = predictions.scored(index)
    preds = {name: predictions.prediction(name, index) for name in names}
    # Scales from every scored pixel of the frame, not only the shown ones.
    error_max = style.error_scale([np.abs(p - gt)[scored] for p in preds.values()])
    widths = {name: predictions.width(name, index) for name in names}
    width_max = style.error_scale([w[scored] for w in widths.values() if w is not None])
    rows, cols = sample_grid(gt.shape, width)
    k = gt.shape[1] / width  # frame pixels per shown pixel: hole lines as wide as in `inpaintenv show`

    def shown(a: np.ndarray) -> np.ndarray:
        return a[rows][:, cols]

    hole_s, gt_s, scored_s, view_s = _shown_hole(hole, rows, cols), shown(gt), shown(scored), shown(predictions.view(index))
    scan = INPUTS[predictions.input_kind].separate
    x = shown(_shown_input(predictions.method_input(index), max(1, round(k)) if scan else 1))
    inp = style.draw_holes(style.depth_rgb(x, max_depth), hole_s, hatch=True, scale=k)
    truth = style.draw_holes(style.depth_rgb(gt_s, max_depth), hole_s, scale=k)
    what = "hole" if predictions.protocol.task == "hole" else "unmeasured pixels"
    intervals = any(w is not None for w in widths.values())
    out = []
    for name, pred in preds.items():
        p = shown(pred)
        row = [
            (inp, ("scan" if scan else "input") + (" (holes hatched)" if hole.any() else ""), "black"),
            (truth, "ground truth (grey = no data)", "black"),
            (style.draw_holes(style.depth_rgb(np.where(view_s, p, 0.0), max_depth), hole_s, scale=k),
             _scores(predictions, name, index, pred, max_depth), colours.get(name, "black")),
            (style.draw_holes(style.error_rgb(np.abs(p - gt_s), scored_s, error_max), hole_s, scale=k),
             f"|error| in the {what}, 0-{error_max:g} m", "black"),
        ]
        if intervals:
            w = widths[name]
            row.append((style.draw_holes(style.error_rgb(np.zeros_like(gt_s) if w is None else shown(w),
                                                         scored_s & (w is not None), width_max), hole_s, scale=k),
                        "no interval" if w is None else
                        f"interval width ({predictions.coverage:g}), 0-{width_max:g} m", "black"))
        out.append(row)
    bars = [(0, 3, style.DEPTH_CMAP, max_depth, "depth (m)"), (3, 1, style.ERROR_CMAP, error_max, "|error| (m)")]
    if intervals:
        bars.append((4, 1, style.ERROR_CMAP, width_max, "interval width (m)"))
    return PanelTiles("", out, bars)


def draw_panel(tiles: PanelTiles, *, pad: int = 10, gap: int = 14, points: float = 8) -> Any:
    """The panel of ``tiles`` as one matplotlib figure: the title, per method a row of titled tiles, the
    colour bars (sizes in pixels; text in ``points``)."""
    th, tw = tiles.rows[0][0][0].shape[:2]
    n_cols = max(len(r) for r in tiles.rows)
    line = int(np.ceil(points * 100 / 72 * 1.25))  # a line of tile title, in pixels
    head = pad + 2 * (line + 2) + 8
    row_h = 2 * line + 6 + th + 6
    bar_h = 12 + 10 + 2 * int(np.ceil(points * 100 / 72))
    width = 2 * pad + n_cols * tw + (n_cols - 1) * gap
    height = head + len(tiles.rows) * row_h + 8 + bar_h + pad
    fig = image_figure(width, height)
    text(fig, width / 2, pad, tiles.title, points + 2, fit=width - 2 * pad)
    for r, row in enumerate(tiles.rows):
        y = head + r * row_h + 2 * line + 6
        for c, (img, title, colour) in enumerate(row):
            x = pad + c * (tw + gap)
            tile(fig, img, x, y)
            text(fig, x + tw / 2, y - 3, title, points, colour, va="bottom", fit=tw + gap - 2)
    y = head + len(tiles.rows) * row_h + 8
    for col, span, cmap, top, label in tiles.bars:
        colourbar(fig, pad + col * (tw + gap), y, span * tw + (span - 1) * gap, cmap, top, label, points)
    return fig


def frame_panel(
    methods: Mapping[str, Any],
    dataset: DepthDataset,
    index: int,
    path: str | Path,
    *,
    protocol: str = "rect-v1",
    seed: int = 0,
    max_depth: float = 80.0,
    colours: Mapping[str, Any] | None = None,
    predictions: FramePredictions | None = None,
) -> Path:
    """The study's Fig. 2 for one frame, in the look of ``inpaintenv show``.

    Per method a row of input (holes hatched), ground truth, reconstruction (method name
    in its run colour, the task's and all-pixel metrics) and absolute error on the task's
    pixels (the hole, or under ``densify-v1`` every pixel the scan lacks); holes outlined on
    every tile; one colour bar for depth and one for the error (robust scale shared by the
    rows, :func:`inpaintenv.report.style.error_scale`), both in metres; with the ``coverage``
    of ``predictions``, a fifth column: each method's interval width (grey: no interval). Pixels without
    ground truth are grey in the truth and error tiles; on a scan, the fill's pixels outside
    the band of rows the LiDAR covers (:meth:`FramePredictions.view`) are grey too: nothing
    there can be judged, and ``fill --missing`` leaves them empty. Tiles are :data:`TILE_WIDTH`
    pixels wide (nearest pixel); the scores and scales come from every pixel of the frame.
    """
    predictions = predictions or FramePredictions(methods, dataset, protocol, seed)
    tiles = panel_tiles(predictions, index, list(methods), max_depth=max_depth, colours=colours)
    scan = INPUTS[predictions.input_kind].separate
    task = protocol if not scan else f"{protocol} on single scans (grey above the scan's rows: outside its view)"
    tiles.title = f"{dataset.frame_ids[index]} — {task}, seed {seed}"
    return save_png(figure_png(draw_panel(tiles)), path)
