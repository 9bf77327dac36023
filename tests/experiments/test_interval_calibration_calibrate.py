"""experiments/interval_calibration.py calibrate: the shipped calibration from fold models, each drive scored by its day's fold."""

from __future__ import annotations

import json

import numpy as np
import pytest

from inpaintenv.data.io import write_depth_png

from stand_ins import FoldTen

DAYS = {"2011_09_26": ("9001", "9002"), "2011_09_30": ("9018",)}


@pytest.fixture
def two_days(tmp_path):
    rng = np.random.default_rng(0)
    for day, numbers in DAYS.items():
        for n in numbers:
            folder = tmp_path / "train" / f"{day}_drive_{n}_sync" / "proj_depth" / "groundtruth" / "image_02"
            folder.mkdir(parents=True)
            for f in range(2):
                depth = np.where(rng.random((375, 1242)) < 0.3, 5.0 + 20 * rng.random((375, 1242)), 0.0)
                write_depth_png(folder / f"{f:010d}.png", depth.astype(np.float32))
    return tmp_path


def test_every_drive_is_calibrated_by_the_fold_model_without_its_day(load_experiment, two_days, tmp_path,
                                                                      monkeypatch, capsys):
    import estimators.learned

    drives = {day: [f"{day}_drive_{n}_sync" for n in numbers] for day, numbers in DAYS.items()}
    every = sorted(d for ds in drives.values() for d in ds)
    models = {f"m-{day}": FoldTen([d for d in every if not d.startswith(day)]) for day in DAYS}
    monkeypatch.setattr(estimators.learned, "load", lambda path: models[str(path)])
    monkeypatch.setattr(estimators.learned, "load_release", lambda name: FoldTen(every))
    out = load_experiment("interval_calibration").main(["calibrate", 
        "--kitti-root", str(two_days), "--out", str(tmp_path / "cal.json"), "--spread-method", "nearest",
        *[a for day in DAYS for a in ("--fold", f"{day}=m-{day}")]])
    cal = json.loads(out.read_text())["calibration"]
    assert cal["drives"] == every and cal["n_frames"] == 2 * len(every)
    assert [f["drives"] for f in cal["out_of_fold"]] == [drives[day] for day in DAYS]
    assert "3 drives" in capsys.readouterr().out


def test_a_day_without_a_fold_is_refused(load_experiment, two_days, tmp_path, monkeypatch):
    import estimators.learned

    monkeypatch.setattr(estimators.learned, "load", lambda path: FoldTen([]))
    with pytest.raises(SystemExit, match="no fold scores drives"):
        load_experiment("interval_calibration").main(["calibrate", 
            "--kitti-root", str(two_days), "--out", str(tmp_path / "cal.json"), "--fold", "2011_09_26=m"])


def test_without_folds_a_release_is_calibrated_on_the_drives_it_never_saw(load_experiment, two_days, tmp_path,
                                                                           monkeypatch):
    import estimators.learned

    monkeypatch.setattr(estimators.learned, "load_release",
                        lambda name: FoldTen(["2011_09_26_drive_9001_sync"]))
    out = load_experiment("interval_calibration").main(["calibrate", 
        "--kitti-root", str(two_days), "--out", str(tmp_path / "cal.json"), "--spread-method", "nearest",
        "--protocol", "mixed-v1"])
    data = json.loads(out.read_text())
    assert data["calibration"]["drives"] == ["2011_09_26_drive_9002_sync", "2011_09_30_drive_9018_sync"]
    assert data["params"]["protocol"] == "mixed-v1" and "out_of_fold" not in data["calibration"]


def test_a_classical_fill_is_calibrated_on_every_drive(load_experiment, two_days, tmp_path):
    out = load_experiment("interval_calibration").main(["calibrate", 
        "--kitti-root", str(two_days), "--release", "scanline", "--out", str(tmp_path / "cal.json"),
        "--spread-method", "nearest", "--frames-per-drive", "1"])
    data = json.loads(out.read_text())
    every = sorted(f"{day}_drive_{n}_sync" for day, numbers in DAYS.items() for n in numbers)
    assert data["base"] == "scanline" and data["calibration"]["drives"] == every
    assert data["params"]["spread_method"] == "nearest" and "out_of_fold" not in data["calibration"]


def _write_scan_drives(root, seed: int) -> list[str]:
    """One random KITTI-sized frame (ground truth and a scan of it) for each of three drives under
    ``root/train``, drive 0001 among them; the drives' names."""
    rng = np.random.default_rng(seed)
    drives = ["2011_09_26_drive_0001_sync", "2011_09_26_drive_9001_sync", "2011_09_30_drive_9018_sync"]
    for drive in drives:
        truth = np.where(rng.random((375, 1242)) < 0.3, 5.0 + 20 * rng.random((375, 1242)), 0.0)
        scan = np.where(rng.random((375, 1242)) < 0.15, truth, 0.0)
        for kind, depth in (("groundtruth", truth), ("velodyne_raw", scan)):
            folder = root / "train" / drive / "proj_depth" / kind / "image_02"
            folder.mkdir(parents=True)
            write_depth_png(folder / "0000000000.png", depth.astype(np.float32))
    return drives


def test_a_scan_fill_is_calibrated_on_the_rebuilt_drives_scans_never_on_drive_0001(load_experiment, tmp_path):
    drives = _write_scan_drives(tmp_path, seed=2)
    out = load_experiment("interval_calibration").main(["calibrate", "--kitti-root", str(tmp_path), "--input", "scan",
        "--release", "nearest", "--out", str(tmp_path / "cal.json"), "--spread-method", "harmonic"])
    cal = json.loads(out.read_text())["calibration"]
    assert cal["drives"] == drives[1:] and cal["protocol"] == "densify-v1" and cal["input_kind"] == "scan"
    # Densify scores every pixel the scan did not measure (there is no hole): far more than a rect-v1 hole.
    assert cal["n_pixels"] > 0.5 * 0.3 * 375 * 1242 * 2


def test_several_scan_densities_are_pooled_each_drive_once_per_density(load_experiment, tmp_path):
    drives = _write_scan_drives(tmp_path, seed=4)
    kinds = ["scan-points50-v1", "scan-points25-v1"]
    out = load_experiment("interval_calibration").main([
        "calibrate", "--kitti-root", str(tmp_path), "--input", *kinds, "--release", "nearest",
        "--protocol", "densify-v1+rect-v1", "--out", str(tmp_path / "cal.json"), "--spread-method", "harmonic"])
    cal = json.loads(out.read_text())["calibration"]
    assert cal["input_kind"] == "+".join(kinds) and cal["drives"] == drives[1:] and cal["n_frames"] == 4
    assert [(f["input_kind"], f["drives"]) for f in cal["out_of_fold"]] == [(k, drives[1:]) for k in kinds]
    with pytest.raises(SystemExit, match="distinct scan kinds only"):
        load_experiment("interval_calibration").main(["calibrate", "--kitti-root", str(tmp_path), "--input", "map",
                                                      "scan", "--release", "nearest"])


def test_fold_models_score_their_day_at_each_scan_density(load_experiment, tmp_path, monkeypatch):
    # A learned fill of sparse scans: each fold model scores its left-out day's drives once per density.
    import estimators.learned

    drives = _write_scan_drives(tmp_path, seed=5)
    kinds = ["scan-points50-v1", "scan-points25-v1"]
    models = {day: FoldTen([d for d in drives if not d.startswith(day)]) for day in ("2011_09_26", "2011_09_30")}
    monkeypatch.setattr(estimators.learned, "load", lambda path: models[str(path)])
    monkeypatch.setattr(estimators.learned, "load_release", lambda name: FoldTen(drives))
    out = load_experiment("interval_calibration").main([
        "calibrate", "--kitti-root", str(tmp_path), "--input", *kinds, "--protocol", "densify-v1+rect-v1",
        "--out", str(tmp_path / "cal.json"), "--spread-method", "harmonic", "--release", "kitti-ensemble-v1",
        *[a for day in models for a in ("--fold", f"{day}={day}")]])
    cal = json.loads(out.read_text())["calibration"]
    assert cal["input_kind"] == "+".join(kinds) and cal["drives"] == drives[1:] and cal["n_frames"] == 4
    assert [(f["input_kind"], f["drives"]) for f in cal["out_of_fold"]] == [
        (k, [d]) for d in drives[1:] for k in kinds]  # drive 0001 never, each day by its own fold at each kind
    assert all(not set(f["drives"]) & set(f["training_drives"]) for f in cal["out_of_fold"])


def test_a_map_fill_is_never_calibrated_on_drive_0001(load_experiment, tmp_path):
    # Drive 0001's maps are reported as official results: no calibration may see them, on maps as on scans.
    drives = _write_scan_drives(tmp_path, seed=3)
    out = load_experiment("interval_calibration").main(["calibrate", "--kitti-root", str(tmp_path), "--release",
        "scanline", "--out", str(tmp_path / "cal.json"), "--spread-method", "nearest"])
    cal = json.loads(out.read_text())["calibration"]
    assert cal["drives"] == drives[1:] and cal["n_frames"] == 2 and cal["protocol"] == "rect-v1"
    assert "input_kind" not in cal or cal["input_kind"] == "map"


def test_condition_edges_bin_the_calibrated_condition_and_the_file_loads(load_experiment, tmp_path):
    from estimators.intervals import load_intervals

    _write_scan_drives(tmp_path, seed=5)
    out = load_experiment("interval_calibration").main([
        "calibrate", "--kitti-root", str(tmp_path), "--input", "scan", "--release", "nearest", "--out",
        str(tmp_path / "cal.json"), "--signals", "border", "depth", "--condition", "frame_density",
        "--condition-edges", "0.05,0.2"])
    assert json.loads(out.read_text())["condition"]["edges"] == [0.05, 0.2]
    loaded = load_intervals(out)
    assert loaded.condition == "frame_density" and loaded.condition_["edges"] == [0.05, 0.2]
