"""Ctrl-C: one line saying what is kept and how to resume, exit 130."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

from inpaintenv.cli import main

classical = pytest.importorskip("estimators.classical")

COMMON = ["--frame-shape", "32", "96", "--n-frames", "8", "--holdout", "0", "--figure-frames", "0",
          "--batch-size", "2", "--quiet"]


def interrupt_after(monkeypatch, cls, calls: int) -> None:
    """Make ``cls.predict`` raise KeyboardInterrupt at its ``calls + 1``-th call."""
    original = cls.predict
    count = [0]

    def predict(self, X):
        count[0] += 1
        if count[0] > calls:
            raise KeyboardInterrupt
        return original(self, X)

    monkeypatch.setattr(cls, "predict", predict)


def test_benchmark_ctrl_c_is_one_line_keeps_rows_and_resumes(tmp_path, capsys, monkeypatch):
    argv = ["benchmark", "-m", "scanline", *COMMON, "--out", str(tmp_path)]
    interrupt_after(monkeypatch, classical.ScanlineInpainter, 3)  # the untimed warm-up call, two batches
    assert main(argv) == 130
    err = capsys.readouterr().err
    assert err.strip() == (f"inpaintenv benchmark: interrupted; the rows scored so far are kept in "
                           f"{tmp_path / 'rows'}; rerun the same command to resume")
    rows = (tmp_path / "rows" / "scanline__rect-v1.jsonl").read_text().splitlines()
    assert len(rows) == 4  # two batches of two
    monkeypatch.undo()
    assert main(argv) == 0
    assert "| scanline | rect-v1 | 8 |" in capsys.readouterr().out


def test_evaluate_ctrl_c_is_one_line_and_keeps_the_rows_of_out(tmp_path, capsys, monkeypatch):
    interrupt_after(monkeypatch, classical.ConstantInpainter, 1)
    argv = ["evaluate", "-m", "constant", "--frame-shape", "32", "96", "--n-frames", "8", "--batch-size", "2",
            "--quiet", "--out", str(tmp_path)]
    assert main(argv) == 130
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("inpaintenv evaluate: interrupted; the rows scored so far")
    assert str(tmp_path / "partial-rows.jsonl") in err and "rerun the same command" in err
    rows = [json.loads(line) for line in (tmp_path / "partial-rows.jsonl").read_text().splitlines()]
    assert [r["index"] for r in rows] == [0, 1]
    monkeypatch.undo()
    assert main(argv) == 0
    assert not (tmp_path / "partial-rows.jsonl").exists()  # a finished run leaves only its results


def test_train_ctrl_c_is_one_line(tmp_path, capsys, monkeypatch):
    pytest.importorskip("torch")
    import estimators.learned.presets

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(estimators.learned.presets, "train_preset", interrupted)
    assert main(["train", "--preset", "smoke", "--n-frames", "4", "--frame-shape", "32", "96",
                 "--out", str(tmp_path), "--quiet"]) == 130
    err = capsys.readouterr().err.strip().splitlines()
    # Stopped before any step: nothing to keep.
    assert err[-1] == ("inpaintenv train: interrupted; no checkpoint was written (this run stopped before its first "
                       "one, at the end of the first epoch); rerun the same command to start again")


def test_train_says_whether_it_resumes_or_starts_over(tmp_path, capsys):
    pytest.importorskip("torch")
    argv = ["train", "--preset", "smoke", "--n-frames", "4", "--frame-shape", "32", "96",
            "--out", str(tmp_path), "--quiet"]
    assert main([*argv, "--max-steps", "1"]) == 0
    assert f"starting a new training run in {tmp_path}" in capsys.readouterr().err
    assert main([*argv, "--max-steps", "1"]) == 0
    assert "already finished" in capsys.readouterr().err  # nothing to resume
    state = json.loads((tmp_path / "train_args.json").read_text())
    (tmp_path / "train_args.json").write_text(json.dumps({k: v for k, v in state.items() if k != "finished"}))
    assert main([*argv, "--max-steps", "1"]) == 0  # as if killed after its last checkpoint
    assert "resuming the run in" in capsys.readouterr().err
    assert main([*argv, "--max-steps", "2"]) == 0
    err = capsys.readouterr().err
    assert f"starting over in {tmp_path}: --max-steps changed (1 -> 2)" in err
    assert "Checkpoints are keyed by every training parameter" in err
    log = json.loads((tmp_path / "training_log.json").read_text())
    assert log["n_steps"] == 2


SLOW = textwrap.dedent("""
    import signal, sys, time
    import numpy as np
    from inpaintenv.cli import main
    from inpaintenv.methods.registry import register_method

    class Slow:
        def predict(self, X):
            time.sleep(0.3)
            return np.nan_to_num(X, nan=10.0)

    sys.modules["slowmod"] = type(sys)("slowmod")
    sys.modules["slowmod"].Slow = Slow
    register_method("slow", "slowmod", "Slow")
    # A shell that starts pytest in the background without job control makes its
    # children ignore SIGINT, and Python then keeps SIG_IGN; Ctrl-C must reach main().
    signal.signal(signal.SIGINT, signal.default_int_handler)
    sys.exit(main(sys.argv[1:]))
""")


#: Starts the rest of its command line with SIGINT ignored, as a shell without job control
#: starts a background job (an ignored signal stays ignored across exec).
IGNORING_SIGINT = ("import os, signal, sys; signal.signal(signal.SIGINT, signal.SIG_IGN); "
                   "os.execv(sys.executable, [sys.executable, *sys.argv[1:]])")


@pytest.mark.slow
@pytest.mark.parametrize("inherited", ["default", "ignored"])
def test_benchmark_sigint_in_a_subprocess(tmp_path, inherited):
    # "ignored": the child starts with SIGINT ignored, as under `nohup`-less `pytest &` in a script.
    argv = ["benchmark", "-m", "slow", *COMMON, "--n-frames", "40", "--out", str(tmp_path)]
    prefix = [sys.executable, "-c", IGNORING_SIGINT] if inherited == "ignored" else [sys.executable]
    proc = subprocess.Popen([*prefix, "-c", SLOW, *argv], stderr=subprocess.PIPE, text=True)
    rows = tmp_path / "rows" / "slow__rect-v1.jsonl"
    deadline = time.monotonic() + 60
    while not (rows.exists() and rows.stat().st_size) and time.monotonic() < deadline:
        time.sleep(0.05)
    os.kill(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130
    assert "Traceback" not in err
    assert err.strip().splitlines() == [
        (f"inpaintenv benchmark: interrupted; the rows scored so far are kept in {tmp_path / 'rows'}; "
         "rerun the same command to resume")
    ]
    assert rows.read_text().count("\n") >= 2
