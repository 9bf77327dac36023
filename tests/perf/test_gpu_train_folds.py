"""perf/gpu_train_folds.py: ``--quick`` trains every fold on the CPU and prints scoring commands that run."""

from __future__ import annotations

import json
import os
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
pytest.importorskip("torch")


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("folds")
    done = subprocess.run([sys.executable, "perf/gpu_train_folds.py", "--quick"], cwd=REPO,
                          env={**os.environ, "OUT": str(out)}, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    return out, done.stdout


def test_folds_leave_out_each_day_and_drive_0001_and_never_share_a_drive(load_benchmark):
    m = load_benchmark("gpu_train_folds")
    drives = ["2011_09_26_drive_0001_sync", "2011_09_26_drive_9001_sync", "2011_09_30_drive_9018_sync",
              "2011_10_03_drive_9027_sync"]
    folds = {f.name: f for f in m.make_folds(drives)}
    assert list(folds) == ["day-2011_09_26", "day-2011_09_30", "day-2011_10_03", "drive-0001"]
    assert folds["day-2011_09_26"].held == ("2011_09_26_drive_0001_sync", "2011_09_26_drive_9001_sync")
    assert folds["drive-0001"].train == tuple(drives[1:]) and folds["drive-0001"].camera == "both"
    for fold in folds.values():
        assert not set(fold.train) & set(fold.held) and set(fold.train) | set(fold.held) >= set(drives) - {
            "2011_09_26_drive_0001_sync"}
    with pytest.raises(ValueError, match="no drive left to train on"):
        m.make_folds(["2011_09_26_drive_9001_sync"])


@pytest.mark.timeout(60)
def test_quick_run_saves_each_fold_and_its_scoring_command_scores_it(quick_run, capsys):
    from inpaintenv.cli import main

    out, stdout = quick_run
    commands = (out / "score_folds.sh").read_text().splitlines()[2:]
    assert len(commands) == 4 and all(c in stdout for c in commands)
    for name in ("day-2011_09_26", "day-2011_09_30", "day-2011_10_03", "drive-0001"):
        record = json.loads((out / name / "fold.json").read_text())
        assert not set(record["train_drives"]) & set(record["held_drives"])
        assert [s["steps"] for s in record["stages"].values()] == [2, 2]
        assert (out / name / "unet-tv" / "model.safetensors").stat().st_size > 0
    # The printed command scores the fold's U-Net on its left-out frames (one classical method here, for time).
    argv = shlex.split(commands[-1])
    argv[argv.index("--suite"):argv.index("--suite") + 2] = ["--method", "constant"]
    assert main([*argv[1:], "--quiet"]) == 0
    assert "study-unet-tv-gpu-without-drive-0001" in capsys.readouterr().out


def test_score_only_reads_the_left_out_drives_of_the_whole_data_and_refuses_a_trained_one(quick_run, load_benchmark):
    m = load_benchmark("gpu_train_folds")
    out, _ = quick_run
    root = out / "synthetic-kitti"
    folds = {f.name: f for f in m.scored_folds(root, out)}
    assert folds["drive-0001"].held == ("2011_09_26_drive_0001_sync",)
    assert m.main(["--score-only", "--kitti-root", str(root), "--out", str(out)]) == 0
    record = json.loads((out / "drive-0001" / "fold.json").read_text())
    (out / "drive-0001" / "fold.json").write_text(json.dumps({**record, "train_drives": [
        *record["train_drives"], "2011_09_26_drive_0001_sync"]}))
    with pytest.raises(ValueError, match="trained on .*2011_09_26_drive_0001_sync"):
        m.scored_folds(root, out)
