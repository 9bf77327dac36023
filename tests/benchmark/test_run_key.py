"""What keys a run folder: the data's content and the message naming the
setting that differs."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

from inpaintenv.benchmark import RunMismatchError, run_benchmark
from inpaintenv.benchmark.datakey import data_key
from inpaintenv.cli import main
from inpaintenv.data import ArrayDataset, KittiDepth, SyntheticStreets
from inpaintenv.data.io import read_depth_png, write_depth_png

pytest.importorskip("estimators.classical")

DRIVES = ("2011_09_26_drive_0001_sync", "2011_09_26_drive_0002_sync")


@pytest.fixture
def kitti_copy(tmp_path):
    """A KITTI layout of 2 drives x 2 small frames; returns the root."""
    root = tmp_path / "kitti"
    rng = np.random.default_rng(0)
    for drive in DRIVES:
        folder = root / "train" / drive / "proj_depth" / "groundtruth" / "image_02"
        folder.mkdir(parents=True)
        for k in range(2):
            depth = np.where(rng.random((375, 1242)) < 0.3, 5.0 + 20 * rng.random((375, 1242)), 0.0)
            write_depth_png(folder / f"{k:010d}.png", depth.astype(np.float32))
    return root


def halve(path):
    write_depth_png(path, read_depth_png(path) / 2)


def bench(root, out, *methods, extra=()):
    argv = ["benchmark", "--kitti-root", str(root), "--figure-frames", "0", "--out", str(out), "--quiet", *extra]
    for m in methods:
        argv += ["-m", m]
    return main(argv)


def test_a_resume_on_changed_ground_truth_is_refused(kitti_copy, tmp_path, capsys):
    out = tmp_path / "run"
    assert bench(kitti_copy, out, "constant") == 0
    first = json.loads((out / "results.json").read_text())["rows"]
    # Halve every ground-truth PNG of one drive and rerun with one more method.
    for png in sorted((kitti_copy / "train" / DRIVES[1]).rglob("*.png")):
        halve(png)
    assert bench(kitti_copy, out, "constant", "nearest") == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert "holds results of a different run" in err and "the ground truth changed" in err
    assert f"drive {DRIVES[1]}" in err and DRIVES[0] not in err and "--no-resume" in err
    assert json.loads((out / "results.json").read_text())["rows"] == first  # nothing mixed
    # --no-resume scores everything again on the new data.
    assert bench(kitti_copy, out, "constant", "nearest", extra=["--no-resume"]) == 0
    rows = json.loads((out / "results.json").read_text())["rows"]
    assert {r["method"] for r in rows} == {"constant", "nearest"}


def test_unchanged_data_resumes_and_a_touched_file_counts_as_changed(kitti_copy, tmp_path):
    ds = KittiDepth(kitti_copy, split="train")
    key = data_key(ds, len(ds))
    assert set(key) == set(DRIVES)
    assert data_key(KittiDepth(kitti_copy, split="train"), len(ds)) == key
    png = ds.paths[0]
    st = os.stat(png)
    os.utime(png, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))
    changed = data_key(KittiDepth(kitti_copy, split="train"), len(ds))
    assert changed[DRIVES[0]] != key[DRIVES[0]] and changed[DRIVES[1]] == key[DRIVES[1]]


def test_arrays_are_keyed_by_their_content(small_gt, tmp_path):
    ten = {"ten": lambda x: np.where(np.isnan(x), 10.0, x)}
    run_benchmark(ten, ArrayDataset(small_gt), out_dir=tmp_path, progress=False)
    with pytest.raises(RunMismatchError, match="the ground truth changed"):
        run_benchmark(ten, ArrayDataset(small_gt / 2), out_dir=tmp_path, progress=False)
    run_benchmark(ten, ArrayDataset(small_gt.copy()), out_dir=tmp_path, progress=False)  # same values: resumes
    assert data_key(SyntheticStreets(n=2, frame_shape=(32, 64)), 2) == {}  # its description fixes it


def test_a_folder_from_before_data_keys_still_resumes(small_gt, tmp_path):
    ten = {"ten": lambda x: np.where(np.isnan(x), 10.0, x)}
    run_benchmark(ten, ArrayDataset(small_gt), out_dir=tmp_path, progress=False)
    state = json.loads((tmp_path / "run.json").read_text())
    del state["data"]
    (tmp_path / "run.json").write_text(json.dumps(state))
    run_benchmark(ten, ArrayDataset(small_gt), out_dir=tmp_path, progress=False)
    assert "data" in json.loads((tmp_path / "run.json").read_text())  # recorded from then on


def test_the_message_names_the_setting_that_differs(tmp_path, capsys):
    common = ["-m", "telea-hole", "--n-frames", "2", "--frame-shape", "32", "96", "--holdout", "0",
              "--figure-frames", "0", "--quiet", "--out", str(tmp_path)]
    assert main(["benchmark", *common]) == 0
    assert main(["benchmark", *common, "--unfilled", "interpolate"]) == 1
    err = capsys.readouterr().err.strip()
    assert "--unfilled: not given (each method's own policy) there, interpolate now" in err, err
    assert "seeds" not in err and "protocols" not in err and "source" not in err
    assert main(["benchmark", *common, "--seed", "3"]) == 1
    err = capsys.readouterr().err.strip()
    assert "the seeds (--seed): [0] there, [3] now" in err and "--unfilled" not in err
