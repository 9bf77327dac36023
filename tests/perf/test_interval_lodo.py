"""perf/interval_lodo.py: each day left out, calibrated on the others, never on a drive the base saw."""

from __future__ import annotations

import json

import numpy as np
import pytest

from inpaintenv.data.io import write_depth_png

from stand_ins import FoldTen

DRIVES = ["2011_09_26_drive_9001_sync", "2011_09_26_drive_9002_sync", "2011_09_30_drive_9018_sync",
          "2011_09_30_drive_9020_sync"]


@pytest.fixture(scope="module")
def two_days(tmp_path_factory):
    """Two frames of each drive in DRIVES (read only: the tests write their outputs elsewhere)."""
    root = tmp_path_factory.mktemp("two_days")
    rng = np.random.default_rng(0)
    for drive in DRIVES:
        folder = root / "train" / drive / "proj_depth" / "groundtruth" / "image_02"
        folder.mkdir(parents=True)
        for f in range(2):
            depth = np.where(rng.random((375, 1242)) < 0.3, 5.0 + 20 * rng.random((375, 1242)), 0.0)
            write_depth_png(folder / f"{f:010d}.png", depth.astype(np.float32))
    return root


def test_folds_rows_and_curve(load_benchmark, two_days, tmp_path, capsys):
    rows = load_benchmark("interval_lodo").main(["--kitti-root", str(two_days), "--spread-method", "nearest",
                                                 "--frames-per-drive", "0", "--json", str(tmp_path / "rows.json")])
    assert [r["fold"] for r in rows] == ["day-2011_09_26", "day-2011_09_30"]
    assert all(r["n_cal_drives"] == 2 and r["n_frames"] == 4 and 0 < r["hole_coverage"] <= 1 for r in rows)
    assert all(np.isfinite([r["rmse_keep_90"], r["rmse_keep_50"], r["rejection_auc"]]).all() for r in rows)
    assert json.loads((tmp_path / "rows.json").read_text()) == rows
    assert all(r["hole_coverage_se"] >= 0 and np.isfinite(r["rmse_cut_80_se"]) for r in rows)
    out = capsys.readouterr().out
    assert "| fold | protocol | keep 90 % | keep 80 % | keep 50 % | all | AUC |" in out and "| day-2011_09_30 | rect-v1 |" in out


def test_weighting_reaches_the_wrapper(load_benchmark, two_days):
    by = {w: load_benchmark("interval_lodo").main(["--kitti-root", str(two_days), "--spread-method", "nearest",
                                                   "--frames-per-drive", "0", "--weighting", w]) for w in ("frame", "pixel")}
    # Same scale model, another quantile: the width changes; the ranking only where low is clipped at 0 m.
    assert [r["rmse_cut_80"] for r in by["frame"]] == pytest.approx([r["rmse_cut_80"] for r in by["pixel"]], abs=0.01)
    assert [r["hole_interval_width"] for r in by["frame"]] != [r["hole_interval_width"] for r in by["pixel"]]


def test_standard_error_is_numpys(load_benchmark):
    se = load_benchmark("interval_lodo").standard_error
    values = [0.8, 0.95, float("nan"), 0.9, 1.0]
    finite = np.array([0.8, 0.95, 0.9, 1.0])
    assert se(values) == pytest.approx(finite.std(ddof=1) / 2)
    assert np.isnan(se([0.9])) and np.isnan(se([float("nan"), 0.9]))


def test_drives_the_base_saw_are_neither_calibrated_nor_scored(load_benchmark, two_days, monkeypatch):
    import inpaintenv.methods.registry

    monkeypatch.setattr(inpaintenv.methods.registry, "make_method", lambda name: FoldTen([DRIVES[0]]))
    rows = load_benchmark("interval_lodo").main(["--kitti-root", str(two_days), "--method", "saw-one-drive",
                                                 "--signals", "border", "--frames-per-drive", "0"])
    by_fold = {r["fold"]: r for r in rows}
    assert by_fold["day-2011_09_26"]["n_frames"] == 2      # 9002 only: 9001 was the base's
    assert by_fold["day-2011_09_30"]["n_cal_drives"] == 1  # calibrated on 9002 only


def test_on_maps_drive_0001_never_calibrates_a_fold_as_it_never_calibrates_the_shipped_one(load_benchmark):
    folds = load_benchmark("interval_lodo").folds([*DRIVES, "2011_09_26_drive_0001_sync"])
    assert [name for name, _, _ in folds] == ["day-2011_09_26", "day-2011_09_30", "drive-0001"]
    assert all("2011_09_26_drive_0001_sync" not in cal for _, cal, _ in folds)
    assert folds[1][1] == DRIVES[:2] and folds[2] == ("drive-0001", DRIVES, ["2011_09_26_drive_0001_sync"])
    assert "2011_09_26_drive_0001_sync" in folds[0][2]  # scored with its day, as every drive of it

@pytest.fixture
def scans(tmp_path):
    """Two days of drives, plus official drive 0001, a frame each with a ground truth and a sparser scan."""
    rng = np.random.default_rng(1)
    for drive in [*DRIVES, "2011_09_26_drive_0001_sync"]:
        for f in range(1):
            truth = np.where(rng.random((375, 1242)) < 0.3, 5.0 + 20 * rng.random((375, 1242)), 0.0)
            scan = np.where(rng.random((375, 1242)) < 0.15, truth, 0.0)
            for kind, depth in (("groundtruth", truth), ("velodyne_raw", scan)):
                folder = tmp_path / "train" / drive / "proj_depth" / kind / "image_02"
                folder.mkdir(parents=True, exist_ok=True)
                write_depth_png(folder / f"{f:010d}.png", depth.astype(np.float32))
    return tmp_path


def test_on_scans_each_day_and_the_official_drive_are_scored_under_densify_and_rect(load_benchmark, scans):
    rows = load_benchmark("interval_lodo").main(["--kitti-root", str(scans), "--input", "scan", "--method", "nearest",
                                                 "--spread-method", "harmonic", "--frames-per-drive", "0"])
    assert [(r["fold"], r["protocol"]) for r in rows] == [
        (fold, p) for fold in ("day-2011_09_26", "day-2011_09_30", "drive-0001") for p in ("densify-v1", "rect-v1")]
    by = {(r["fold"], r["protocol"]): r for r in rows}
    # Drive 0001 (official) never calibrates: the day folds calibrate on the other day's two rebuilt drives.
    assert all(r["n_cal_drives"] == 2 for r in rows if r["fold"] != "drive-0001")
    assert by[("drive-0001", "densify-v1")]["n_cal_drives"] == 4
    # Every pixel the scan leaves to fill is scored: densify has no hole yet a coverage.
    assert all(0 < r["hole_coverage"] <= 1 and np.isfinite(r["hole_rmse"]) for r in rows)
