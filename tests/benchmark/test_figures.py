"""The benchmark's figures: one colour per method, every drive, no needless re-prediction."""

from __future__ import annotations

import matplotlib.colors as mcolors
import numpy as np
import pytest

from inpaintenv.report import plots, style
from inpaintenv.benchmark import figures, panels
from inpaintenv.cli import main
from inpaintenv.data import ArrayDataset

pytest.importorskip("estimators.classical")

METHODS = ["scanline", "constant", "nearest", "harmonic", "ipbasic"]
# 16 synthetic frames: two drives of 8.
OPTIONS = ["--n-frames", "16", "--frame-shape", "64", "192", "--holdout", "0", "--figure-frames", "1", "--quiet"]


def argv_of(methods: list[str]) -> list[str]:
    return ["benchmark", *[a for m in methods for a in ("-m", m)], *OPTIONS]


ARGV = argv_of(METHODS)


@pytest.fixture
def drawn(monkeypatch):
    """Per figure file name: {line label: colour} and the title; and the count of re-predictions."""
    record: dict[str, dict] = {"predict": 0}
    save = figures._save_plot
    run = figures.run_method

    def spy_save(fig, path):  # the matplotlib figure about to be encoded: its lines and title as drawn
        lines = {ln.get_label(): mcolors.to_hex(ln.get_color()) for ln in fig.axes[0].get_lines()}
        record[path.name] = {"lines": lines, "titles": [t.get_text() for t in fig.texts]}
        return save(fig, path)

    def spy_run(*args, **kwargs):
        record["predict"] += 1
        return run(*args, **kwargs)

    monkeypatch.setattr(figures, "_save_plot", spy_save)
    monkeypatch.setattr(figures, "run_method", spy_run)
    return record


def test_one_colour_per_method_in_every_figure_and_frames_from_every_drive(tmp_path, drawn):
    assert main([*ARGV, "--out", str(tmp_path)]) == 0
    run_colours = {m: mcolors.to_hex(c) for m, c in style.method_colours(METHODS).items()}
    size = drawn["error_vs_hole_size.png"]["lines"]
    distance = drawn["error_vs_distance.png"]["lines"]
    assert size == run_colours  # every method, in its run colour
    assert distance and all(distance[m] == run_colours[m] for m in distance)  # the best four, same colours
    assert "spread over 2 of 2 drives" in drawn["error_vs_distance.png"]["titles"][0]
    assert "every frame-mask of the run (16)" in drawn["error_vs_hole_size.png"]["titles"][0]


def test_rerun_with_everything_done_does_not_predict_again(tmp_path, drawn, capsys):
    argv = [a for a in ARGV if a != "--quiet"] + ["--out", str(tmp_path)]
    assert main(argv) == 0
    assert drawn["predict"] == 0  # the run's own predictions of the spread frames are drawn
    err = capsys.readouterr().err
    assert "figures (rect-v1): the pixels of 4 methods on 8 frames spread over 2 of 2 drives kept" in err
    assert main(argv) == 0
    assert drawn["predict"] == 0  # nothing new: figures already show these rows
    assert "already show these rows; not redrawn" in capsys.readouterr().err
    (tmp_path / "figures" / "figures.json").unlink()
    assert main(argv) == 0  # every row on disk: the figures alone need the pixels, and only theirs
    assert drawn["predict"] == 4 * 8  # the four best methods on the 8 spread frames, once each (panel frames shared)
    line = next(x for x in capsys.readouterr().err.splitlines() if x.startswith("figures (rect-v1): running"))
    assert "4 methods again on 8 frames spread over 2 of 2 drives" in line and "the rows do not keep" in line


def test_figures_run_again_only_the_methods_an_earlier_run_scored(tmp_path, drawn):
    first = ["--out", str(tmp_path), "--figure-frames", "0"]
    assert main([*argv_of(METHODS[:2]), *first]) == 0
    assert drawn["predict"] == 0
    assert main([*ARGV, "--out", str(tmp_path)]) == 0  # three new methods scored now, two resumed
    drawn_methods = set(drawn["error_vs_distance.png"]["lines"])
    resumed = drawn_methods & set(METHODS[:2])
    assert drawn["predict"] == 8 * len(resumed)  # only the resumed methods' frames are predicted again


def test_spread_indices_cover_the_drives_in_turn():
    data = ArrayDataset(np.ones((10, 8, 8), np.float32), groups=["a"] * 6 + ["b"] * 3 + ["c"])
    picked = figures.spread_indices(data, 5)
    assert [str(data.groups[i]) for i in picked[:3]] == ["a", "b", "c"]
    assert picked == [0, 6, 9, 5, 8]  # a: first and last of its 6, b: first and last of its 3, c: its one
    assert sorted(figures.spread_indices(data, 50)) == list(range(10))


def test_scan_panel_shows_no_fill_above_the_scans_rows(tmp_path):
    """A fill of a scan is drawn only inside the band of rows the LiDAR covers: above it nothing can be
    judged, and fills that extrapolate there drew vertical streaks."""
    from inpaintenv.data import SyntheticStreets
    from inpaintenv.filling.view import sensor_view
    from inpaintenv.report.raster import sample_grid

    data = SyntheticStreets(n=1, frame_shape=(48, 160), input="scan")
    everywhere = lambda x: np.where(np.isnan(x), np.float32(10.0), x)  # fills every pixel, sky included
    predictions = figures.FramePredictions({"ten": everywhere}, data, "densify-v1", 0)
    tiles = panels.panel_tiles(predictions, 0, ["ten"])
    rows, cols = sample_grid(data.frame_shape, panels.TILE_WIDTH)
    view = sensor_view(data.load_pairs([0])[0][0])[rows][:, cols]  # as the tile shows the frame
    assert (~view).any() and view.any()
    fill_tile = tiles.rows[0][2][0]
    assert fill_tile.shape[:2] == view.shape
    assert np.allclose(fill_tile[~view], style.NO_DATA)  # grey outside the scan's band
    assert (~np.isclose(fill_tile[view], style.NO_DATA).all(axis=-1)).mean() > 0.9  # the fill inside it
    path = panels.frame_panel({"ten": everywhere}, data, 0, tmp_path / "p.png", protocol="densify-v1")
    assert path.read_bytes().startswith(b"\x89PNG")


def test_figures_colour_only_the_shown_pixels_and_resample_no_full_frame(tmp_path, monkeypatch):
    """What a run's figures cost is bounded by what they show: every tile is coloured at its shown size
    (never a full frame wider than a tile) and placed pixel for pixel (:func:`inpaintenv.report.plots.tile`:
    no axes per tile, no image for matplotlib to resample), and nothing is predicted again. Counted, not
    timed: a timing would be flaky on a loaded machine."""
    import matplotlib.axes

    shapes: list[tuple[int, ...]] = []
    depth_rgb = style.depth_rgb
    monkeypatch.setattr(style, "depth_rgb", lambda d, m: (shapes.append(np.shape(d)), depth_rgb(d, m))[1])
    placed: list[tuple[int, ...]] = []
    pixels = plots._pixels_artist()
    init = pixels.__init__
    monkeypatch.setattr(pixels, "__init__", lambda self, X, *a: (placed.append(np.shape(X)), init(self, X, *a))[1])
    shown: list[tuple[int, ...]] = []
    imshow = matplotlib.axes.Axes.imshow
    monkeypatch.setattr(matplotlib.axes.Axes, "imshow", lambda ax, X, *a, **k: (shown.append(np.shape(X)), imshow(ax, X, *a, **k))[1])
    predicted: list[int] = []
    run = figures.run_method
    monkeypatch.setattr(figures, "run_method", lambda *a, **k: (predicted.append(1), run(*a, **k))[1])
    panel_axes: list[int] = []
    draw_panel = panels.draw_panel
    monkeypatch.setattr(panels, "draw_panel", lambda *a, **k: (fig := draw_panel(*a, **k), panel_axes.append(len(fig.axes)))[0])
    argv = ["benchmark", "-m", "scanline", "-m", "nearest", "--n-frames", "4", "--frame-shape", "64", "760",
            "--holdout", "0", "--figure-frames", "2", "--quiet", "--out", str(tmp_path)]
    assert main(argv) == 0
    assert len(shapes) == 2 * (2 + 2)  # two panels: the input and truth tiles once, a fill tile per method
    assert all(s[1] == panels.TILE_WIDTH for s in shapes), shapes  # 380 px shown of the 760-px frames
    assert len(placed) == 2 * 2 * 4 and all(s[1] == panels.TILE_WIDTH for s in placed), placed  # 2 panels x 2 rows x 4 tiles
    assert shown == []  # no image on axes: nothing resampled at draw time
    assert panel_axes == [2, 2]  # a panel's only axes are its two colour bars
    assert predicted == []  # the run's own predictions are drawn
    drawn = {p.name for p in (tmp_path / "figures").glob("*.png")}
    assert len({n for n in drawn if n.startswith("frame_")}) == 2
    assert {"error_vs_hole_size.png", "error_vs_distance.png", "error_vs_nearest.png"} <= drawn
