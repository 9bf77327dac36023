"""The benchmark's figures through matplotlib: line and box plots, tiles, colour bars, PNG bytes."""

from __future__ import annotations

import cv2
import matplotlib.colors as mcolors
import numpy as np

from inpaintenv.report import plots, style
from inpaintenv.report.raster import png_bytes, sample_grid

RED, BLUE = (255, 0, 0), (0, 0, 255)


def _pixels(png: bytes) -> np.ndarray:
    return cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_COLOR)[..., ::-1]


def _near(img: np.ndarray, rgb: tuple[int, int, int], tol: int = 40) -> int:
    return int((np.abs(img.astype(int) - rgb).max(axis=-1) <= tol).sum())


def test_png_bytes_are_lossless():
    rgb = np.random.default_rng(0).integers(0, 256, (7, 11, 3), dtype=np.uint8)
    assert np.array_equal(_pixels(png_bytes(rgb)), rgb)


def _lines(ys: list[float]) -> list[plots.Line]:
    return [plots.Line("red", [0, 1, 2, 3], ys, "#ff0000"), plots.Line("blue", [0, 3], [1, 1], "#0000ff", "--"),
            plots.Line("no points", [], [], "green"), plots.Line("all NaN", [1, 2], [np.nan, np.nan], "black")]


def test_each_line_in_its_colour_nan_breaks_it_and_empty_lines_draw():
    fig = plots.line_figure(_lines([0, 0, 0, 0]), "title", "x", "y")
    ax = fig.axes[0]
    drawn = {ln.get_label(): ln for ln in ax.get_lines()}
    assert list(drawn) == ["red", "blue", "no points", "all NaN"]
    assert mcolors.to_hex(drawn["red"].get_color()) == "#ff0000" and drawn["blue"].get_linestyle() == "--"
    assert [t.get_text() for t in ax.get_legend().get_texts()] == list(drawn)
    assert (ax.get_xlabel(), ax.get_ylabel(), [t.get_text() for t in fig.texts]) == ("x", "y", ["title"])
    whole = _pixels(plots.figure_png(fig))
    assert whole.shape == (460, 640, 3)
    broken = _pixels(plots.figure_png(plots.line_figure(_lines([0, 0, np.nan, 0]), "title", "x", "y")))
    assert _near(whole, RED) > _near(broken, RED) > 0  # the segments into and out of the NaN are not drawn
    assert _near(whole, BLUE) > 0


def test_the_shared_line_figure_keeps_nothing_of_the_last_plot():
    plots.line_figure([plots.Line("a", [1, 4, 64], [3, 2, 1], "red")], "first", "px", "m", log_x=True, invert_x=True)
    fig = plots.line_figure([plots.Line("b", [0, 1], [5, 6], "blue")], "second", "x", "y")
    ax = fig.axes[0]
    assert [ln.get_label() for ln in ax.get_lines()] == ["b"] and [t.get_text() for t in fig.texts] == ["second"]
    assert ax.get_xscale() == "linear" and not ax.xaxis_inverted()
    assert ax.get_xlim()[0] < 0 < 1 < ax.get_xlim()[1] and ax.get_ylim()[0] < 5 < 6 < ax.get_ylim()[1]


def test_log_and_inverted_axes_leave_out_x_at_zero_and_place_the_legend_off_the_points():
    fig = plots.line_figure([plots.Line("a", [0, 1, 4, 64], [3, 2, 1, 0.5], "#ff0000")], "t", "px", "m",
                            log_x=True, invert_x=True)
    ax = fig.axes[0]
    assert ax.get_xscale() == "log" and ax.xaxis_inverted()
    x = ax.get_lines()[0].get_xdata()
    assert np.isnan(x[0]) and list(x[1:]) == [1, 4, 64]  # x = 0 has no place on a log axis: left out
    assert [t.get_text() for t in ax.get_xticklabels() if t.get_text()] and "$" not in "".join(
        t.get_text() for t in ax.get_xticklabels())  # plain numbers, not mathtext
    assert _near(_pixels(plots.figure_png(fig)), RED) > 0
    # Points falling from the upper left to the lower right: the legend goes to a corner they leave free.
    falling = plots.line_figure([plots.Line("a", [0, 1, 2, 3], [3, 2, 1, 0], "red")], "t", "x", "y")
    assert falling.axes[0].get_legend()._loc in (1, 3)  # upper right or lower left


def test_boxes_one_per_name_first_at_the_top_in_their_colours():
    fig = plots.box_figure({"a": [1.0, 2.0, 3.0, 40.0], "b": [5.0]}, {"a": "#0000ff", "b": "#ff0000"}, "t",
                           "RMSE (m)")
    ax = fig.axes[0]
    assert [t.get_text() for t in ax.get_yticklabels()] == ["a", "b"] and ax.yaxis_inverted()
    assert [mcolors.to_hex(p.get_facecolor()[:3]) for p in ax.patches] == ["#0000ff", "#ff0000"]
    img = _pixels(plots.figure_png(fig))
    assert img.shape[1] == 576 and img.shape[0] > 2 * 25


def test_text_that_is_not_utf8_or_holds_dollars_is_set_as_written():
    fig = plots.image_figure(300, 40)
    plots.text(fig, 150, 5, "frame \udcff.png costs $5 and $6", 9)  # not UTF-8, as Python reads it; no mathtext
    assert fig.texts[0].get_text() == "frame \\udcff.png costs \\$5 and \\$6"
    assert (_pixels(plots.figure_png(fig)) < 255).any()


def test_tiles_are_placed_pixel_for_pixel_and_sampling_is_nearest():
    rgb = np.random.default_rng(1).random((9, 13, 3)).astype(np.float32)
    fig = plots.image_figure(40, 30)
    plots.tile(fig, rgb, 5, 7)
    img = _pixels(plots.figure_png(fig))
    assert img.shape == (30, 40, 3)
    assert np.array_equal(img[7:16, 5:18], style.to_uint8(rgb))
    rows, cols = sample_grid((10, 40), 20)
    assert list(cols) == list(range(1, 40, 2)) and list(rows) == list(range(1, 10, 2))


def test_colour_bar_shows_the_map_over_its_scale():
    fig = plots.image_figure(300, 60)
    plots.colourbar(fig, 10, 5, 280, style.DEPTH_CMAP, 80.0, "depth (m)")
    cax = fig.axes[0]
    assert cax.get_xlim() == (0.0, 80.0) and cax.get_xlabel() == "depth (m)"
    img = _pixels(plots.figure_png(fig))
    lut = style.to_uint8(style.lookup_table(style.DEPTH_CMAP))
    assert np.abs(img[10, 12].astype(int) - lut[0]).max() <= 8  # near: the map's first colour
    assert np.abs(img[10, 287].astype(int) - lut[-1]).max() <= 8  # far: its last
