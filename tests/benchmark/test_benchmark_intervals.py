"""The benchmark scores per-pixel intervals when asked (--interval-coverage / interval_coverage)."""

from __future__ import annotations

import json

import matplotlib.colors as mcolors
import numpy as np
import pytest

from inpaintenv.benchmark import RunMismatchError, run_benchmark, write_report
from inpaintenv.benchmark import figure_files, figures, panels
from inpaintenv.cli import main
from inpaintenv.data import ArrayDataset
from inpaintenv.metrics import border_distance
from inpaintenv.report import style


class TenPlusMinus:
    """Fills 10 m; its interval is 10 m ± (1 + 0.2·distance to the hole border)."""

    def predict(self, x):
        return np.where(np.isnan(x), 10.0, x).astype(np.float32)

    def predict_interval(self, x, coverage=0.9):
        p = self.predict(x)
        half = 1.0 + 0.2 * border_distance(np.isnan(x))
        return np.maximum(p - half, 0.0), p + half


def ten_metres(x):
    return np.where(np.isnan(x), 10.0, x)


@pytest.fixture
def dataset(small_gt):
    return ArrayDataset(np.concatenate([small_gt, small_gt + 1.0]), groups=["d0"] * 3 + ["d1"] * 3)


def test_interval_columns_only_for_methods_that_give_one(dataset, tmp_path):
    res = run_benchmark({"iv": TenPlusMinus(), "ten": ten_metres}, dataset, out_dir=tmp_path, progress=False,
                        interval_coverage=0.9)
    iv = [r for r in res.rows if r["method"] == "iv"]
    ten = [r for r in res.rows if r["method"] == "ten"]
    assert all(0 <= r["hole_coverage"] <= 1 and r["hole_interval_width"] > 0 for r in iv)
    assert all("hole_coverage" not in r and "rmse_keep_80" not in r for r in ten)
    # Same prediction, same base columns: the interval changes nothing else.
    assert [r["hole_rmse"] for r in iv] == [r["hole_rmse"] for r in ten]
    assert res.meta["interval_coverage"] == 0.9 and res.meta["interval_methods"] == ["iv"]
    paths = write_report(res, tmp_path)
    md = paths["markdown"].read_text()
    assert "hole coverage" in md and "80 % nearest border" in md
    table = json.loads(paths["json"].read_text())["table"]
    assert table[0]["rejection_auc"] == pytest.approx(np.mean([r["rejection_auc"] for r in iv]))
    assert "hole_coverage" in paths["table_csv"].read_text().splitlines()[0]


def test_rows_are_unchanged_without_the_option(dataset, tmp_path):
    plain = run_benchmark({"iv": TenPlusMinus()}, dataset, out_dir=tmp_path / "a", progress=False)
    assert "hole_coverage" not in plain.rows[0] and "interval_coverage" not in plain.meta
    md = write_report(plain, tmp_path / "a")["markdown"].read_text()
    assert "coverage" not in md


def test_resuming_with_another_coverage_is_refused(dataset, tmp_path):
    run_benchmark({"ten": ten_metres}, dataset, out_dir=tmp_path, progress=False)
    with pytest.raises(RunMismatchError, match="interval_coverage"):
        run_benchmark({"ten": ten_metres}, dataset, out_dir=tmp_path, progress=False, interval_coverage=0.9)


@pytest.mark.parametrize("coverage", [0.0, 1.0, 90])
def test_bad_coverage_is_refused_before_scoring(dataset, tmp_path, coverage):
    with pytest.raises(ValueError, match="interval_coverage"):
        run_benchmark({"ten": ten_metres}, dataset, out_dir=tmp_path, progress=False, interval_coverage=coverage)
    assert not (tmp_path / "rows").exists()


def test_error_rejection_figure_from_the_rows(dataset, tmp_path, monkeypatch):
    res = run_benchmark({"iv": TenPlusMinus(), "ten": ten_metres}, dataset, out_dir=tmp_path, progress=False,
                        interval_coverage=0.9)
    drawn = {}
    save = figures._save_plot

    def spy(fig, path):  # the matplotlib figure about to be encoded: each line's colour and points as drawn
        drawn[path.name] = {ln.get_label(): (mcolors.to_hex(ln.get_color()), list(ln.get_ydata()))
                            for ln in fig.axes[0].get_lines()}
        return save(fig, path)

    monkeypatch.setattr(figures, "_save_plot", spy)
    names = figure_files.write_figures(res, {"iv": TenPlusMinus, "ten": lambda: ten_metres}, dataset,
                                       tmp_path / "figures", panel_methods=["iv"], n_panels=1, protocol="rect-v1", seed=0)
    assert (tmp_path / "figures" / "error_rejection.png") in names
    lines = drawn["error_rejection.png"]
    colour = mcolors.to_hex(style.method_colours(res.methods)["iv"])
    assert set(lines) == {"iv, most confident", "iv, nearest the border"}  # "ten" has no interval
    assert all(c == colour for c, _ in lines.values())
    iv = [r for r in res.rows if r["method"] == "iv"]
    assert lines["iv, most confident"][1] == pytest.approx(
        [np.mean([r[c] for r in iv]) for c in ("hole_rmse", "rmse_keep_90", "rmse_keep_80", "rmse_keep_50")])


def test_cli_option(tmp_path, monkeypatch, capsys):
    (tmp_path / "ivmod.py").write_text(
        "import numpy as np\n"
        "class Method:\n"
        "    def predict(self, x):\n"
        "        return np.where(np.isnan(x), 10.0, x).astype(np.float32)\n"
        "    def predict_interval(self, x, coverage=0.9):\n"
        "        p = self.predict(x)\n"
        "        return np.maximum(p - 5.0, 0.0), p + 5.0\n"
    )
    monkeypatch.chdir(tmp_path)
    argv = ["benchmark", "-m", "ivmod:Method", "--n-frames", "4", "--frame-shape", "64", "96", "--holdout", "0",
            "--figure-frames", "1", "--quiet", "--out", str(tmp_path / "run"), "--interval-coverage", "0.9"]
    assert main(argv) == 0
    assert (tmp_path / "run" / "figures" / "error_rejection.png").is_file()
    assert (tmp_path / "run" / "figures" / "uncertainty.png").is_file()  # reliability diagram, AUSE and AURG
    assert (tmp_path / "run" / "figures" / "coverage_vs_nearest.png").is_file()  # conditional coverage
    assert "Conditional coverage" in (tmp_path / "run" / "report.html").read_text()
    assert "AUSE RMSE per image (m)" in (tmp_path / "run" / "results.md").read_text()
    assert "hole coverage" in (tmp_path / "run" / "results.md").read_text()
    capsys.readouterr()
    assert main([*argv[:-1], "1.5", "--out", str(tmp_path / "bad")]) == 1
    err = capsys.readouterr().err.strip()
    assert "--interval-coverage" in err and "(0, 1)" in err and len(err.splitlines()) == 1
    assert not (tmp_path / "bad").exists()


def test_frame_panel_shows_the_interval_width_of_a_method_that_has_one(dataset, tmp_path):
    from inpaintenv.metrics import as_coverage

    predictions = figures.FramePredictions({"iv": TenPlusMinus(), "ten": ten_metres}, dataset, "rect-v1", 0,
                                           coverage=as_coverage(0.9))
    width = predictions.width("iv", 0)
    hole = predictions.frame(0)[1]
    assert width is not None and (width[hole] >= 2.0).all()  # 10 m ± (1 + 0.2 d): at least 2 m wide in the hole
    assert predictions.width("ten", 0) is None  # a plain callable has no interval
    shown = [title for row in panels.panel_tiles(predictions, 0, list(predictions.methods)).rows for _, title, _ in row]
    assert sum(t.startswith("interval width (0.9)") for t in shown) == 1 and "no interval" in shown
    panels.frame_panel(predictions.methods, dataset, 0, tmp_path / "p.png", predictions=predictions)
    assert (tmp_path / "p.png").read_bytes().startswith(b"\x89PNG")


def test_conditional_coverage_figure_is_the_numpy_share_per_bin(dataset, tmp_path, monkeypatch):
    """coverage_by_bin.png: each method with an interval, its coverage per distance-to-measurement and per
    depth bin, as NumPy counts it on the same frames; a method without an interval is not drawn."""
    import cv2

    from inpaintenv.benchmark import coverage_figure
    from inpaintenv.masks import get_protocol

    res = run_benchmark({"iv": TenPlusMinus(), "ten": ten_metres}, dataset, out_dir=tmp_path, progress=False,
                        interval_coverage=0.9)
    drawn = {}
    encode = coverage_figure.figure_png

    def spy(fig):  # the matplotlib figure about to be encoded: each line's points as drawn
        ax = fig.axes[0]
        drawn[ax.get_xlabel()] = {ln.get_label(): (list(ln.get_xdata()), list(ln.get_ydata())) for ln in ax.get_lines()}
        return encode(fig)

    monkeypatch.setattr(coverage_figure, "figure_png", spy)
    names = figure_files.write_figures(res, {"iv": TenPlusMinus, "ten": lambda: ten_metres}, dataset,
                                       tmp_path / "figures", panel_methods=["iv", "ten"], n_panels=1,
                                       protocol="rect-v1", seed=0)
    assert {tmp_path / "figures" / "coverage_vs_nearest.png", tmp_path / "figures" / "coverage_vs_distance.png"} <= set(names)
    assert all(p.read_bytes().startswith(b"\x89PNG") for p in names if p.name.startswith("coverage"))
    by_distance, by_depth = drawn["distance to the nearest measured pixel (px)"], drawn["ground-truth depth (m)"]
    assert set(by_distance) == {"iv", "nominal 0.9"} and by_distance["nominal 0.9"][1] == [0.9, 0.9]
    near, deep = np.asarray(figures.NEAREST_BINS, float), np.asarray(figures.DISTANCE_BINS, float)
    hits = {"d": np.zeros(len(near) - 1), "z": np.zeros(len(deep) - 1)}
    n = {"d": np.zeros(len(near) - 1), "z": np.zeros(len(deep) - 1)}
    for i in figures.spread_indices(dataset, figures.DISTANCE_FRAMES):
        gt = dataset.load_pairs([i])[1][0]
        hole = get_protocol("rect-v1").mask(gt.shape, 0, i)
        x = np.where(hole, np.nan, gt)
        low, high = TenPlusMinus().predict_interval(x[None])
        scored = hole & (gt > 0)
        inside = ((gt >= low[0]) & (gt <= high[0]))[scored]
        dist = cv2.distanceTransform((~(np.nan_to_num(x) > 0)).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
        for key, value, edges in (("d", dist[scored], near), ("z", gt[scored], deep)):
            which = np.digitize(value, edges[1:-1])
            n[key] += np.bincount(which, minlength=len(edges) - 1)
            hits[key] += np.bincount(which, weights=inside, minlength=len(edges) - 1)
    for (_, drawn_y), key in ((by_distance["iv"], "d"), (by_depth["iv"], "z")):
        seen = n[key] > 0  # an empty bin draws no point
        np.testing.assert_allclose(drawn_y, hits[key][seen] / n[key][seen])
    assert min(by_distance["iv"][1]) < max(by_distance["iv"][1])  # the share changes with the distance
