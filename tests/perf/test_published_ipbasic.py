"""perf/published_ipbasic.py on a tiny synthetic KITTI layout, with a stand-in for the published code."""

from __future__ import annotations

import textwrap

import numpy as np
import pytest

from estimators.classical import IPBasicInpainter
from inpaintenv.data import write_depth_png

DRIVE = "2011_09_26_drive_0001_sync"
SHAPE = (24, 40)

# Not the published code: a fill whose result is easy to recompute. The mean of the
# measured pixels everywhere; without extrapolation the top row stays empty (0 m), which
# the devkit's background interpolation fills from the row below.
STAND_IN = '''
import numpy as np

def fill_in_fast(depth_map, max_depth=100.0, extrapolate=False, blur_type="bilateral"):
    mean = depth_map[depth_map > 0].mean()
    depth_map[depth_map == 0] = mean
    if not extrapolate:
        depth_map[0] = 0.0
    return depth_map
'''


def _frame(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """A (scan, truth) pair on the 1/256 m grid, so the PNGs store them exactly."""
    truth = np.round(rng.uniform(4.0, 60.0, SHAPE) * 256) / 256
    truth[rng.random(SHAPE) < 0.3] = 0.0
    scan = np.where(rng.random(SHAPE) < 0.15, truth + 0.5, 0.0)
    scan[3, 5] = 20.0  # at least one measurement
    return scan.astype(np.float32), truth.astype(np.float32)


@pytest.fixture
def layout(tmp_path):
    """A KITTI root with two val_selection frames and three drive frames, and a stand-in clone."""
    rng = np.random.default_rng(0)
    root, frames = tmp_path / "kitti", {}
    folder = root / "depth_selection" / "val_selection_cropped"
    for i in (5, 8):
        scan, truth = frames[f"val{i}"] = _frame(rng)
        stem = f"{DRIVE.replace('0001', '0002')}_{{}}_{i:010d}_image_02.png"
        write_depth_png(folder / "velodyne_raw" / stem.format("velodyne_raw"), scan)
        write_depth_png(folder / "groundtruth_depth" / stem.format("groundtruth_depth"), truth)
    drive = root / "train" / DRIVE / "proj_depth"
    for camera, i in (("image_02", 5), ("image_02", 6), ("image_03", 5)):
        scan, truth = frames[f"{camera}/{i}"] = _frame(rng)
        write_depth_png(drive / "velodyne_raw" / camera / f"{i:010d}.png", scan)
        write_depth_png(drive / "groundtruth" / camera / f"{i:010d}.png", truth)
    write_depth_png(drive / "velodyne_raw" / "image_02" / "0000000099.png", scan)  # no truth: left out
    clone = tmp_path / "ip_basic"
    (clone / "ip_basic").mkdir(parents=True)
    (clone / "ip_basic" / "depth_map_utils.py").write_text(textwrap.dedent(STAND_IN))
    return root, clone, frames


def _numpy_scores(pred: np.ndarray, scan: np.ndarray, truth: np.ndarray) -> tuple[float, float, float]:
    err = pred.astype(np.float64) - truth
    m, u = truth > 0, (truth > 0) & (scan == 0)
    return (1000 * np.sqrt(np.mean(err[m] ** 2)), 1000 * np.mean(np.abs(err[m])),
            1000 * np.sqrt(np.mean(err[u] ** 2)))


def test_table_numbers_equal_a_numpy_recomputation(load_benchmark, layout, capsys):
    bench = load_benchmark("published_ipbasic")
    root, clone, frames = layout
    tables = bench.main(["--ip-basic", str(clone), "--kitti-root", str(root)])
    assert set(tables) == {"val_selection_cropped", DRIVE, "all frames"}
    ordered = [frames["val5"], frames["val8"], frames["image_02/5"], frames["image_02/6"], frames["image_03/5"]]
    expect = {}
    for scan, truth in ordered:
        paper = np.where(scan > 0, scan, scan[scan > 0].mean())
        readme = paper.copy()
        readme[0] = readme[1]  # the devkit's background interpolation of the empty top row
        ours = IPBasicInpainter().predict(np.where(scan > 0, scan, np.nan))
        for name, pred in ((bench.PAPER, paper), (bench.RECOMMENDED, readme), ("ipbasic", ours)):
            expect.setdefault(name, []).append(_numpy_scores(pred, scan, truth))
    rows = {row["method"]: row for row in tables["all frames"]}
    assert bench.MULTISCALE not in rows  # the stand-in has no fill_in_multiscale
    for name, scores in expect.items():
        rmse, mae, unmeasured = np.mean(scores, axis=0)
        assert rows[name]["rmse"] == f"{rmse:.1f}" and rows[name]["mae"] == f"{mae:.1f}"
        assert rows[name]["unmeasured_rmse"] == f"{unmeasured:.1f}"
    ratio = np.mean([s[0] for s in expect["ipbasic"]]) / np.mean([s[0] for s in expect[bench.PAPER]])
    assert rows["ipbasic"]["vs"] == bench.PAPER
    assert rows["ipbasic"]["rmse_ratio"].startswith(f"{ratio:.3f} [") and "(rough)" in rows["ipbasic"]["rmse_ratio"]
    assert {"harmonic", "nearest", "scanline"} <= set(rows)
    assert rows[bench.RECOMMENDED]["empty"] == f"{100 / SHAPE[0]:.1f}" and rows[bench.PAPER]["empty"] == "0.0"
    printed = capsys.readouterr().out
    assert "### all frames (5 frames, crop none)" in printed and "| ipbasic | " in printed
    both = [(s > 0) & (t > 0) for s, t in ordered]
    scan_rmse = np.mean([1000 * np.sqrt(np.mean((s[b] - t[b].astype(np.float64)) ** 2)) for (s, t), b in zip(ordered, both)])
    assert f"The scan against the truth where both exist: RMSE {scan_rmse:.1f} mm" in printed
    assert f"and {bench.PAPER} differ by more than 0.1 mm on " in printed


def test_per_frame_scores_and_the_devkit_interpolation(load_benchmark):
    bench = load_benchmark("published_ipbasic")
    truth = np.array([[0.0, 10.0, 12.0], [8.0, 0.0, 4.0]], np.float32)
    scan = np.array([[0.0, 10.0, 0.0], [0.0, 0.0, 5.0]], np.float32)
    pred = np.array([[0.0, 11.0, 12.0], [9.0, 6.0, 4.0]], np.float32)  # (0, 0) filled by the row: 11
    got = bench.frame_scores(pred, truth, scan)
    err = np.array([1.0, 0.0, 1.0, 0.0])  # the four ground-truth pixels
    assert got["rmse"] == pytest.approx(1000 * np.sqrt(np.mean(err**2)))
    assert got["mae"] == pytest.approx(1000 * np.mean(err))
    assert got["unmeasured_rmse"] == pytest.approx(1000 * np.sqrt(np.mean([0.0, 1.0])))  # (0, 2) and (1, 0)


def test_a_clone_without_the_published_module_is_refused(load_benchmark, tmp_path):
    with pytest.raises(FileNotFoundError, match="kujason/ip_basic"):
        load_benchmark("published_ipbasic").load_published(tmp_path)
