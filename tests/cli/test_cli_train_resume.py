"""``inpaintenv train`` resumes what it left: a run stopped by ``--max-minutes`` continues on the
next call, and a full disk is one line that leaves no checkpoint a resume would take."""

from __future__ import annotations

import json

import pytest

from inpaintenv.cli import main

pytest.importorskip("torch")

SMOKE = ["train", "--preset", "smoke", "--synthetic", "--n-frames", "2", "--frame-shape", "32", "64", "--quiet"]
FULL_DISK = "Error while serializing: I/O error: No space left on device (os error 28)"


def _one_error(err: str) -> str:
    assert "Traceback" not in err, err
    errors = [line for line in err.splitlines() if line.startswith("inpaintenv train:")]
    assert len(errors) == 1, err
    return errors[0]


def test_a_run_stopped_by_max_minutes_resumes_when_run_again(tmp_path, capsys, monkeypatch):
    from estimators.learned import _budget

    looks = iter(range(0, 10_000, 60))  # one minute further on at every look
    monkeypatch.setattr(_budget, "clock", lambda: float(next(looks)))
    out = tmp_path / "run"
    assert main([*SMOKE, "--max-steps", "4", "--max-minutes", "1.5", "--out", str(out)]) == 0
    assert json.loads((out / "training_log.json").read_text())["n_steps"] == 2
    capsys.readouterr()
    monkeypatch.setattr(_budget, "clock", lambda: 0.0)
    assert main([*SMOKE, "--max-steps", "4", "--out", str(out)]) == 0
    assert "resuming the run" in capsys.readouterr().err
    log = json.loads((out / "training_log.json").read_text())
    assert log["n_steps"] == 4 and len(log["history"]["step_loss"]) == 4
    assert main([*SMOKE, "--max-steps", "4", "--out", str(out)]) == 0  # finished now: nothing to do
    assert "already finished" in capsys.readouterr().err


@pytest.mark.parametrize("failing, kept", [(3, "ckpt-00000001-"), (5, "ckpt-00000002-")],
                         ids=["checkpoint", "model"])
def test_a_full_disk_is_one_line_and_leaves_no_partial_checkpoint(tmp_path, capsys, monkeypatch, failing, kept):
    """safetensors' own error on a full disk (its message, as a real full tmpfs gives it)."""
    from safetensors import SafetensorError

    from estimators.learned import _checkpoint

    real, calls = _checkpoint.save_file, [0]

    def full(tensors, path):
        calls[0] += 1
        if calls[0] == failing:  # 1-2: the checkpoint of step 1, 3-4: of step 2, 5: the model
            raise SafetensorError(FULL_DISK)
        return real(tensors, path)

    monkeypatch.setattr(_checkpoint, "save_file", full)
    out = tmp_path / "run"
    assert main([*SMOKE, "--out", str(out)]) == 1
    line = _one_error(capsys.readouterr().err)
    assert "No space left on device" in line and str(out) in line
    run = next((out / "checkpoints").iterdir())
    names = sorted(p.name for p in run.iterdir())
    assert len(names) == 3 and names[0].startswith(kept) and names[1:] == ["run.lock", "state.json"], names
    monkeypatch.setattr(_checkpoint, "save_file", real)
    assert main([*SMOKE, "--out", str(out)]) == 0  # the disk has room again: the run resumes and ends
    assert json.loads((out / "training_log.json").read_text())["n_steps"] == 2
