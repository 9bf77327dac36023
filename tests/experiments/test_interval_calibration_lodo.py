"""experiments/interval_calibration.py lodo: each calibration protocol, one recording day left out, scored as evaluate scores it."""

from __future__ import annotations

import numpy as np
import pytest

from inpaintenv.data.io import write_depth_png

from stand_ins import FoldTen

DAYS = ("2011_09_26", "2011_09_30", "2011_10_03")


@pytest.fixture
def three_days(tmp_path):
    """One drive a day, two frames each, each with a ground truth and a sparser scan."""
    rng = np.random.default_rng(3)
    for day in DAYS:
        base = tmp_path / "train" / f"{day}_drive_9001_sync" / "proj_depth"
        for f in range(2):
            truth = np.where(rng.random((375, 1242)) < 0.3, 5.0 + 20 * rng.random((375, 1242)), 0.0)
            scan = np.where(rng.random((375, 1242)) < 0.15, truth, 0.0)
            for kind, depth in (("groundtruth", truth), ("velodyne_raw", scan)):
                (base / kind / "image_02").mkdir(parents=True, exist_ok=True)
                write_depth_png(base / kind / "image_02" / f"{f:010d}.png", depth.astype(np.float32))
    return tmp_path


def test_each_row_is_the_wrapper_calibrated_out_of_fold_and_scored_by_evaluate(load_experiment, three_days,
                                                                              monkeypatch):
    import estimators.learned
    from estimators.intervals import ConformalIntervalInpainter
    from inpaintenv.data import KittiDepth, spaced_per_drive
    from inpaintenv.evaluate import evaluate

    drives = {day: f"{day}_drive_9001_sync" for day in DAYS}
    models = {f"m-{day}": FoldTen([d for k, d in drives.items() if k != day]) for day in DAYS}
    monkeypatch.setattr(estimators.learned, "load", lambda path: models[str(path)])
    out = load_experiment("interval_calibration").main([
        "lodo", "--kitti-root", str(three_days), "--frames-per-drive", "0", "--seeds", "0,1",
        *[a for day in DAYS for a in ("--fold", f"{day}=m-{day}")]])
    rows = {(r["calibration"], r["day"], r["task"]): r for r in out["rows"]}
    assert len(rows) == 4 * len(DAYS) * 2
    data = KittiDepth(str(three_days), split="train", input="scan")
    frames = {day: spaced_per_drive(data, 0, [drives[day]]) for day in DAYS}
    left = DAYS[1]
    for variant, signals in (("densify-v1", ("border", "depth", "spread")),
                             ("densify-v1+rect-v1 (+far)", ("border", "depth", "spread", "far"))):
        wrapper = ConformalIntervalInpainter(models[f"m-{left}"], spread_method="harmonic", signals=signals,
                                             protocol=variant.split()[0])
        wrapper.fit_out_of_fold([(models[f"m-{d}"], frames[d]) for d in DAYS if d != left])
        for task, seeds in (("densify-v1", [0]), ("rect-v1", [0, 1])):
            scored = evaluate(wrapper, frames[left], protocol=task, seeds=seeds, intervals=0.9, progress=False).rows
            row = rows[(variant, left, task)]
            assert row["coverage"] == pytest.approx(np.mean([r["hole_coverage"] for r in scored]), abs=1e-3)
            assert row["width"] == pytest.approx(np.mean([r["hole_interval_width"] for r in scored]), rel=1e-3)
            assert 0.0 <= row["ause"] < 1.0  # pooled and normalised: 0 for the oracle ranking


def test_map_input_scores_a_classical_fill_on_rect_v1_holes_of_the_maps(load_experiment, three_days):
    from estimators.intervals import ConformalIntervalInpainter
    from inpaintenv.data import KittiDepth, spaced_per_drive
    from inpaintenv.evaluate import evaluate
    from inpaintenv.methods.registry import make_method

    out = load_experiment("interval_calibration").main([
        "lodo", "--kitti-root", str(three_days), "--frames-per-drive", "0", "--seeds", "0,1", "--input", "map",
        "--method", "scanline", "--spread-method", "nearest", "--condition", "none", "--condition", "distance"])
    rows = {(r["condition"], r["day"]): r for r in out["rows"]}
    assert {(r["calibration"], r["task"]) for r in out["rows"]} == {("rect-v1", "rect-v1")}
    assert len(rows) == 2 * len(DAYS)
    data = KittiDepth(str(three_days), split="train", input="map")
    frames = {day: spaced_per_drive(data, 0, [f"{day}_drive_9001_sync"]) for day in DAYS}
    left = DAYS[0]
    wrapper = ConformalIntervalInpainter(make_method("scanline"), spread_method="nearest", protocol="rect-v1")
    wrapper.fit_out_of_fold([(make_method("scanline"), frames[d]) for d in DAYS if d != left])
    scored = evaluate(wrapper, frames[left], protocol="rect-v1", seeds=[0, 1], intervals=0.9, progress=False).rows
    row = rows[("none", left)]
    assert row["coverage"] == pytest.approx(np.mean([r["hole_coverage"] for r in scored]), abs=1e-3)
    assert row["width"] == pytest.approx(np.mean([r["hole_interval_width"] for r in scored]), rel=1e-3)
    with pytest.raises(SystemExit, match="--input map"):
        load_experiment("interval_calibration").main([
            "lodo", "--kitti-root", str(three_days), "--input", "map", "scan", "--method", "scanline"])


@pytest.mark.parametrize("value", ["0.02,0.01", "0.01,abc", "-0.01", "0.01,nan", "0.01,0.01", ""])
@pytest.mark.parametrize("command", ["lodo", "calibrate"])
def test_condition_edges_are_increasing_positive_numbers_or_one_error_naming_the_option(load_experiment, capsys,
                                                                                         command, value):
    with pytest.raises(SystemExit) as stop:
        load_experiment("interval_calibration").main([command, "--kitti-root", "nowhere", "--condition",
                                                      "frame_density", "--condition-edges", value])
    err = capsys.readouterr().err
    assert stop.value.code == 2 and "argument --condition-edges" in err and "increasing positive finite" in err


def test_condition_edges_are_parsed_and_refused_without_their_one_condition(load_experiment):
    module = load_experiment("interval_calibration")
    assert module.edges_option("0.015, 0.03") == (0.015, 0.03)
    for conditions in ([], ["--condition", "none"], ["--condition", "density", "--condition", "frame_density"]):
        with pytest.raises(SystemExit, match="--condition-edges: the bin edges of one --condition"):
            module.main(["lodo", "--kitti-root", "nowhere", "--method", "harmonic", *conditions,
                         "--condition-edges", "0.015,0.03"])
    with pytest.raises(SystemExit, match="--condition-edges: the bin edges of a --condition"):
        module.main(["calibrate", "--kitti-root", "nowhere", "--condition-edges", "0.015,0.03"])


def test_one_bin_per_cell_keeps_its_ranking_and_covers_each_class(load_experiment):
    """Two LiDAR classes (frame densities 0.01 and 0.03), errors four times wider on the sparser one:
    edges between the classes give each class one quantile, so its AUSE is the pooled quantile's (the
    ranking within the class is the scale's), while each class is covered as asked."""
    from estimators.intervals import cell_of, cell_quantiles, fit_condition, residual_quantiles, scale_from

    module = load_experiment("interval_calibration")
    signals = module.FEATURE_SIGNALS

    def frames(seed):
        rng = np.random.default_rng(seed)
        n, per = 16_000, 400  # 40 frames, 20 a class
        frame = np.repeat(np.arange(n // per), per)
        sparse = frame % 2 == 0
        F = np.zeros((n, 1 + len(signals)))
        F[:, 0] = 1.0
        F[:, 1 + signals.index("border")] = np.log1p(rng.uniform(0.0, 30.0, n))
        F[:, 1 + signals.index("depth")] = np.log(80.0)  # the low end never clipped at 0 m
        F[:, 1 + signals.index("frame_density")] = np.where(sparse, 0.01, 0.03)
        coef = np.zeros(1 + len(signals))
        coef[1 + signals.index("border")] = 0.5
        r = scale_from(coef, F) * np.abs(rng.normal(0.0, np.where(sparse, 2.0, 0.5), n)) * rng.uniform(0.5, 1.5, n)
        return coef, F, r, frame, sparse

    coef, F, r, frame, _ = frames(0)
    normed = r / scale_from(coef, F)
    _, q = residual_quantiles(normed, frame, "frame", 0.9)
    found = fit_condition("frame_density", module.edges_option("0.02"), signals, F, normed, frame, "frame", 0.9)
    _, F, r, frame, sparse = frames(1)
    q_cell = cell_quantiles(found, q, 0.9, True, "frame")[cell_of(found, signals, F)]
    for cls in (sparse, ~sparse):
        pooled = module.interval_scores(coef, q, F[cls], r[cls], frame[cls])
        conditioned = module.interval_scores(coef, q_cell[cls], F[cls], r[cls], frame[cls])
        assert conditioned["ause"] == pytest.approx(pooled["ause"], abs=1e-12)
        assert abs(conditioned["coverage"] - 0.9) < 0.02 < abs(pooled["coverage"] - 0.9)


def test_frame_factors_are_each_frame_s_quantile_of_its_normalised_probe_residuals(load_experiment):
    module = load_experiment("interval_calibration")
    rng = np.random.default_rng(0)
    F = np.column_stack([np.ones(600), rng.random(600)])  # intercept, one signal
    coef = np.array([0.5, 1.0])
    frame = np.repeat([0, 2, 3], 200)  # frame 1 has no probe pixel
    r = rng.random(600) * 3.0
    probe = {("rect-v1", 1000): (F[:300], r[:300], frame[:300]), ("rect-v1", 1001): (F[300:], r[300:], frame[300:])}
    factor = module.frame_factors(coef, probe, 0.9)
    normed = r / np.exp(F @ coef)
    want = {f: np.quantile(normed[frame == f], 0.9) for f in (0, 2, 3)}
    median = np.median(list(want.values()))
    got = factor(np.array([0, 1, 2, 3, 7]))
    np.testing.assert_allclose(got, [want[0], median, want[2], want[3], median])


def test_self_check_adds_its_rows_and_leaves_the_others_as_they_were(load_experiment, three_days):
    args = ["lodo", "--kitti-root", str(three_days), "--frames-per-drive", "0", "--seeds", "0", "--input", "map",
            "--method", "scanline", "--spread-method", "nearest"]
    module = load_experiment("interval_calibration")
    plain = module.main(args)["rows"]
    checked = module.main([*args, "--self-check", "1000,1001"])["rows"]
    assert [r for r in checked if r["condition"] == "none"] == plain
    rows = [r for r in checked if r["condition"] == "self-check"]
    assert sorted(r["day"] for r in rows) == sorted(DAYS)
    assert all(0.0 <= r["coverage"] <= 1.0 and r["width"] > 0 and 0.0 <= r["ause"] < 1.0 for r in rows)


@pytest.mark.parametrize("value", ["a,b", "-1", ""])
def test_self_check_seeds_are_whole_numbers_or_one_error_naming_the_option(load_experiment, capsys, value):
    with pytest.raises(SystemExit) as stop:
        load_experiment("interval_calibration").main(["lodo", "--kitti-root", "nowhere", "--method", "harmonic",
                                                      "--self-check", value])
    assert stop.value.code == 2 and "argument --self-check" in capsys.readouterr().err
