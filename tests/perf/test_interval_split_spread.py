"""perf/interval_split_spread.py: coverage over random drive-grouped splits equals the benchmark's."""

from __future__ import annotations

import json

import numpy as np
import pytest

from inpaintenv.data.io import write_depth_png

DRIVES = ["2011_09_26_drive_9001_sync", "2011_09_26_drive_9002_sync", "2011_09_26_drive_9004_sync",
          "2011_09_30_drive_9018_sync", "2011_09_30_drive_9020_sync"]


@pytest.fixture(scope="module")
def five_drives(tmp_path_factory):
    root = tmp_path_factory.mktemp("kitti")
    rng = np.random.default_rng(0)
    rows = np.linspace(4.0, 40.0, 375, dtype=np.float32)[:, None]  # a road-like ramp, noisier per drive
    for n, drive in enumerate(DRIVES):
        folder = root / "train" / drive / "proj_depth" / "groundtruth" / "image_02"
        folder.mkdir(parents=True)
        for f in range(2):
            depth = rows * (1 + 0.1 * n * rng.standard_normal((375, 1242)).astype(np.float32))
            depth = np.where(rng.random((375, 1242)) < 0.3, np.clip(depth, 1.0, 80.0), 0.0)
            write_depth_png(folder / f"{f:010d}.png", depth.astype(np.float32))
    return root


def test_a_split_scores_as_the_benchmark_does(load_benchmark, five_drives):
    from estimators.classical import ScanlineInpainter
    from estimators.intervals import ConformalIntervalInpainter
    from inpaintenv.data import KittiDepth, spaced_per_drive
    from inpaintenv.evaluate import evaluate

    module = load_benchmark("interval_split_spread")
    dataset = KittiDepth(five_drives, split="train")
    for weighting in ("frame", "pixel"):
        wrapper = ConformalIntervalInpainter(ScanlineInpainter(), spread_method="nearest", weighting=weighting)
        residuals = module.drive_residuals(wrapper, dataset, DRIVES, 0)
        # One drive each way: each drive's frames are occluded as a dataset of their own (masks 0, 1, ...).
        coverage = module.split_coverage(wrapper, residuals, DRIVES[1:2], DRIVES[3:4])
        # The same calibration as fit() on that drive ...
        fitted = ConformalIntervalInpainter(ScanlineInpainter(), spread_method="nearest", weighting=weighting)
        fitted.fit(spaced_per_drive(dataset, 0, DRIVES[1:2]))
        assert wrapper.quantile_ == pytest.approx(fitted.quantile_, rel=1e-12)
        np.testing.assert_allclose(wrapper.coef_, fitted.coef_, rtol=1e-10)
        # ... and the coverage evaluate() reports on the scored drives (float32 intervals: a pixel may tip).
        rows = evaluate(fitted, spaced_per_drive(dataset, 0, DRIVES[3:4]), intervals=0.9, progress=False).rows
        assert coverage == pytest.approx(np.mean([r["hole_coverage"] for r in rows]), abs=1e-4)
        # Several calibration drives: their frames stay apart in the frame weighting.
        module.split_coverage(wrapper, residuals, DRIVES[:3], DRIVES[3:])
        frame = np.concatenate([residuals[d][2] + 2 * n for n, d in enumerate(DRIVES[:3])])
        assert wrapper.calibration_["n_frames"] == np.unique(frame).size == 6


def test_summary_of_random_splits_and_days(load_benchmark, five_drives, tmp_path, capsys):
    out = tmp_path / "spread.json"
    summary = load_benchmark("interval_split_spread").main(
        ["--kitti-root", str(five_drives), "--spread-method", "nearest", "--frames-per-drive", "0",
         "--test-drives", "2", "3", "--splits", "6", "--json", str(out)])
    assert json.loads(out.read_text()) == summary
    assert set(summary["random"]) == {"frame/2", "frame/3", "pixel/2", "pixel/3"}
    for row in summary["random"].values():
        cov = np.asarray(row["coverages"])
        assert cov.size == 6 and ((cov > 0) & (cov <= 1)).all()
        assert row["mean"] == pytest.approx(cov.mean()) and row["p05"] <= row["mean"] <= row["p95"]
        assert row["in_band"] == pytest.approx(np.mean((cov >= 0.87) & (cov <= 0.93)))
    days = summary["days"]
    assert days["2011_09_26/frame"]["scored_drives"] == 3 and 0 <= days["2011_09_26/frame"]["rank"] <= 1
    assert days["2011_09_30/pixel"]["scored_drives"] == 2
    printed = capsys.readouterr().out
    assert "| weighting | scored drives | mean | sd | 5-95 % | splits in band |" in printed
    assert "| 2011_09_30 | 2 | frame |" in printed


def test_too_many_scored_drives_is_refused(load_benchmark, five_drives):
    with pytest.raises(SystemExit, match="leave a drive to calibrate on"):
        load_benchmark("interval_split_spread").main(["--kitti-root", str(five_drives), "--test-drives", "5"])
