"""Figures drawn straight into images: line and box plots, the canvas, PNG bytes."""

from __future__ import annotations

import cv2
import numpy as np

from inpaintenv.report import plots
from inpaintenv.report.raster import Canvas, png_bytes, sample_grid

RED, BLUE = (255, 0, 0), (0, 0, 255)


def _pixels(png: bytes) -> np.ndarray:
    return cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_COLOR)[..., ::-1]


def _count(img: np.ndarray, rgb: tuple[int, int, int]) -> int:
    return int((img == rgb).all(axis=-1).sum())


def test_png_bytes_are_lossless():
    rgb = np.random.default_rng(0).integers(0, 256, (7, 11, 3), dtype=np.uint8)
    assert np.array_equal(_pixels(png_bytes(rgb)), rgb)


def test_each_line_in_its_colour_nan_breaks_it_and_empty_lines_draw():
    def drawn(ys: list[float]) -> np.ndarray:
        lines = [plots.Line("red", [0, 1, 2, 3], ys, "#ff0000"), plots.Line("blue", [0, 3], [1, 1], "#0000ff", "--"),
                 plots.Line("no points", [], [], "green"), plots.Line("all NaN", [1, 2], [np.nan, np.nan], "black")]
        img = _pixels(plots.draw_lines(plots.LinePlot(lines, "title", "x", "y")).png())
        assert img.shape == (460, 640, 3)
        return img

    whole, broken = drawn([0, 0, 0, 0]), drawn([0, 0, np.nan, 0])
    assert _count(whole, RED) > _count(broken, RED) > 0  # the segments into and out of the NaN are not drawn
    assert _count(whole, BLUE) > 0


def test_log_and_inverted_axes_and_boxes_draw():
    log = plots.LinePlot([plots.Line("a", [0, 1, 4, 64], [3, 2, 1, 0.5], "#ff0000")], "t", "px", "m", log_x=True,
                         invert_x=True)
    assert _count(_pixels(plots.draw_lines(log).png()), RED) > 0  # x = 0 has no place on a log axis: left out
    boxes = plots.BoxPlot({"a": [1.0, 2.0, 3.0, 40.0], "b": [5.0]}, {"a": "#0000ff", "b": "#ff0000"}, "t", "RMSE (m)")
    img = _pixels(plots.draw_boxes(boxes).png())
    assert img.shape[1] == boxes.width and img.shape[0] > 2 * boxes.row_height


def test_canvas_sets_text_that_is_not_utf8_and_samples_like_nearest():
    canvas = Canvas(200, 40)
    canvas.text(100, 5, "frame \udcff.png", 11)  # a file name that is not UTF-8, as Python reads it
    assert (canvas.pixels() < 255).any()
    rows, cols = sample_grid((10, 40), 20)
    assert list(cols) == list(range(1, 40, 2)) and list(rows) == list(range(1, 10, 2))
