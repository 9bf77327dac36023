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


def test_benchmark_on_unseen_real_drives(kitti_root, kitti_layout, tmp_path, capsys):
    excluded = "2011_09_26_drive_9001_sync"
    argv = [
        "benchmark", "--kitti-root", str(kitti_root), "--split", "train,val",
        "--exclude-drives", excluded, "--method", "scanline",
        "--n-frames", "3", "--figure-frames", "0", "--out", str(tmp_path), "--quiet",
    ]
    assert main(argv) == 0
    doc = json.loads((tmp_path / "results.json").read_text())
    # --n-frames takes the first frames in layout order, from the drives left after the exclusion
    kept = [d for d in kitti_layout("train") if d != excluded]
    scored = {r["drive"] for r in doc["rows"]}
    assert excluded not in scored and kept[0] in scored and scored <= set(kept)
    assert len(doc["rows"]) == 3
    assert all(r["hole_rmse"] > 0 for r in doc["rows"])


def test_rerun_with_another_checkpoint_under_the_same_name_is_refused(tmp_path, capsys):
    torch = pytest.importorskip("torch")
    import numpy as np

    from estimators.learned import UNetInpainter, load
    from inpaintenv.data import ArrayDataset

    rows = np.linspace(30.0, 5.0, 24, dtype=np.float32)[:, None]
    frames = np.stack([rows + k + np.zeros((1, 40), np.float32) for k in range(4)])
    model = UNetInpainter(width=4, depth=2, batch_size=2, epochs=1, random_state=0, num_threads=1)
    model.fit(ArrayDataset(frames, groups=["a", "a", "b", "b"]))
    ck_a = model.save(tmp_path / "ckA")
    other = load(ck_a)
    with torch.no_grad():
        for p in other.model_.parameters():
            p.mul_(1.01)  # another model of the same class and parameters
    ck_b = other.save(tmp_path / "ckB")
    out = tmp_path / "out"
    # --unfilled zero: the one-epoch model's clipped output is 0 m in places (refused by default).
    common = ["-m", "constant", "--frame-shape", "64", "160", "--n-frames", "4", "--holdout", "0",
              "--figure-frames", "0", "--out", str(out), "--quiet", "--unfilled", "zero"]
    assert main(["benchmark", "--checkpoint", f"mine={ck_a}", *common]) == 0
    table = capsys.readouterr().out
    assert main(["benchmark", "--checkpoint", f"mine={ck_b}", *common]) == 1
    err = capsys.readouterr().err
    assert "rows for 'mine'" in err and "were made by checkpoint:" in err and "--no-resume" in err
    # The same checkpoint again resumes (nothing rescored, same table).
    assert main(["benchmark", "--checkpoint", f"mine={ck_a}", *common]) == 0
    assert capsys.readouterr().out == table
    # --no-resume scores the new model.
    assert main(["benchmark", "--checkpoint", f"mine={ck_b}", "--no-resume", *common]) == 0
    assert capsys.readouterr().out != table


def test_corrupt_resume_state_is_one_line_naming_the_file(tmp_path, capsys):
    (tmp_path / "run.json").write_text("{'source': 1}")
    argv = ["benchmark", "-m", "constant", "--frame-shape", "64", "160", "--n-frames", "2", "--holdout", "0",
            "--figure-frames", "0", "--out", str(tmp_path), "--quiet"]
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert str(tmp_path / "run.json") in err and "--no-resume" in err
    assert main([*argv, "--no-resume"]) == 0


def test_study_baselines_are_scored_at_0_m_unless_the_run_says_otherwise(tmp_path, capsys):
    from inpaintenv.cli import main

    # telea-hole leaves 0 m in holes next to unmeasured pixels by design (the study's way):
    # its registered policy scores them as 0 m; --unfilled error refuses them, with a count.
    common = ["-m", "telea-hole", "--n-frames", "4", "--frame-shape", "64", "192", "--holdout", "0", "--figure-frames", "1",
              "--quiet"]
    assert main(["benchmark", *common, "--out", str(tmp_path / "a")]) == 0
    results = json.loads((tmp_path / "a" / "results.json").read_text())
    assert results["meta"]["unfilled"] == {"telea-hole": "zero"}
    capsys.readouterr()
    assert main(["benchmark", *common, "--out", str(tmp_path / "b"), "--unfilled", "error"]) == 1
    assert "method 'telea-hole': prediction is 0 m (unfilled) at" in capsys.readouterr().err
    assert main(["benchmark", *common, "--out", str(tmp_path / "c"), "--unfilled", "interpolate"]) == 0


def test_suite_and_methods_together_score_both(tmp_path, capsys):
    # -m alone replaces the default suite; with an explicit --suite it adds to it (a run
    # that silently lost its classical suite would have no headline to compare against).
    from inpaintenv.benchmark.suites import SUITES

    common = ["--n-frames", "2", "--frame-shape", "64", "192", "--holdout", "0", "--figure-frames", "0",
              "--quiet"]
    assert main(["benchmark", "--suite", "study", "-m", "constant", *common, "--out", str(tmp_path / "a")]) == 0
    methods = {r["method"] for r in json.loads((tmp_path / "a" / "results.json").read_text())["rows"]}
    assert methods == {*SUITES["study"], "constant"}
    assert main(["benchmark", "-m", "constant", *common, "--out", str(tmp_path / "b")]) == 0
    methods = {r["method"] for r in json.loads((tmp_path / "b" / "results.json").read_text())["rows"]}
    assert methods == {"constant"}
    # A name already in the suite is scored once.
    assert main(["benchmark", "--suite", "study", "-m", "telea-hole", *common, "--out", str(tmp_path / "c")]) == 0
    methods = [r["method"] for r in json.loads((tmp_path / "c" / "results.json").read_text())["rows"]]
    assert sorted(set(methods)) == sorted(SUITES["study"]) and len(methods) == 2 * len(SUITES["study"])
