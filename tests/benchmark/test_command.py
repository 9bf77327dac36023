"""``inpaintenv benchmark`` end to end on tiny synthetic frames and on the real slice."""

from __future__ import annotations

import json

import pytest

from inpaintenv.cli import main

pytest.importorskip("estimators.classical")


def test_benchmark_writes_report_and_figures(tmp_path, capsys):
    out = tmp_path / "bench"
    argv = [
        "benchmark", "--method", "scanline", "--method", "constant", "--n-frames", "16",
        "--frame-shape", "64", "192", "--holdout", "0.5", "--protocol", "rect-v1",
        "--protocol", "ego-occlusion-v1", "--out", str(out), "--figure-frames", "1", "--quiet",
    ]
    assert main(argv) == 0
    table = capsys.readouterr().out
    assert "| scanline | rect-v1 |" in table and "| constant | ego-occlusion-v1 |" in table
    doc = json.loads((out / "results.json").read_text())
    assert {r["method"] for r in doc["rows"]} == {"scanline", "constant"}
    assert len({r["drive"] for r in doc["rows"]}) == 1  # one held-out drive of two
    assert doc["meta"]["command"].startswith("inpaintenv benchmark")
    for name in ("frame_0000.png", "error_vs_hole_size.png", "error_vs_distance.png"):
        assert (out / "figures" / name).stat().st_size > 1000
    # Rerunning the same command resumes: nothing left to score, same table.
    assert main(argv) == 0
    assert capsys.readouterr().out == table


def test_benchmark_errors_are_one_line(tmp_path, capsys):
    assert main(["benchmark", "--method", "nope", "--out", str(tmp_path)]) == 1
    assert "unknown method" in capsys.readouterr().err
    assert main(["benchmark", "--method", "constant", "--checkpoint", "x", "--out", str(tmp_path)]) == 1
    assert "NAME=PATH" in capsys.readouterr().err


def test_benchmark_on_unseen_real_drives(kitti_root, tmp_path, capsys):
    argv = [
        "benchmark", "--kitti-root", str(kitti_root), "--split", "train,val",
        "--exclude-drives", "2011_09_26_drive_9001_sync", "--method", "scanline",
        "--n-frames", "3", "--figure-frames", "0", "--out", str(tmp_path), "--quiet",
    ]
    assert main(argv) == 0
    doc = json.loads((tmp_path / "results.json").read_text())
    assert {r["drive"] for r in doc["rows"]} == {"2011_09_26_drive_9002_sync"}
    assert all(r["hole_rmse"] > 0 for r in doc["rows"])
