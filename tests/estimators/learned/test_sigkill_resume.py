"""A training process killed with SIGKILL resumes from its last checkpoint, bit-identically.

The child trains a tiny U-Net with a checkpoint every step; each step is slowed by a
sleep (which changes no number) so the kill lands mid-run. Refitting in this process
with the same parameters and data resumes from the last complete checkpoint. On CPU
with one thread the result is bit-identical to an uninterrupted run: every sample's
crop and mask is seeded by (seed, epoch, index), the epoch order by (seed, epoch), and
the checkpoint holds the exact weights and Adam state.

A damaged checkpoint (a kill cannot produce one, since files are written to a temporary
name and renamed, but a disk can) is **not** skipped: resuming stops with a
``CheckpointError`` naming the file, rather than silently restarting from older state.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from estimators.learned import _neural as neural
from estimators.learned import UNetInpainter
from inpaintenv.exceptions import CheckpointError

# 6 frames in batches of 2: 3 steps per epoch, so max_steps=8 stops mid-epoch 2.
PARAMS = {"width": 4, "depth": 2, "crop": (32, 64), "batch_size": 2, "epochs": 3, "max_steps": 8,
          "checkpoint_every": 1, "random_state": 0, "num_threads": 1, "amp": False}

FRAMES = "np.random.default_rng(0).uniform(2.0, 60.0, (6, 40, 72)).astype(np.float32)"

CHILD = f"""
import time, numpy as np
from estimators.learned import _neural as neural
orig = neural._NeuralInpainter._train_step
def slow(self, *a):
    loss = orig(self, *a)
    time.sleep(0.5)  # room for the parent to kill us mid-run; changes no number
    return loss
neural._NeuralInpainter._train_step = slow
neural.UNetInpainter(**{PARAMS!r}, checkpoint_dir=CKPT).fit({FRAMES})
"""


def _frames() -> np.ndarray:
    return eval(FRAMES)  # the child's exact frames


def _last_step(ckpt: Path) -> int:
    """Step of the last complete checkpoint under ``ckpt`` (0 if none yet)."""
    for state in ckpt.glob("*/state.json"):
        try:
            return int(json.loads(state.read_text())["last"].split("-")[1])
        except (ValueError, KeyError):  # being replaced right now
            return 0
    return 0


@pytest.fixture(scope="module")
def full() -> UNetInpainter:
    return UNetInpainter(**PARAMS).fit(_frames())


@pytest.mark.slow
@pytest.mark.timeout(120)
def test_sigkill_mid_run_resumes_identically(tmp_path, full, monkeypatch):
    ckpt = tmp_path / "ckpt"
    child = subprocess.Popen([sys.executable, "-c", CHILD.replace("CKPT", repr(str(ckpt)))],
                             stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 90
        while _last_step(ckpt) < 3:
            assert child.poll() is None, f"child exited early: {child.stderr.read().decode()[-2000:]}"
            assert time.monotonic() < deadline, "no checkpoint after 90 s"
            time.sleep(0.05)
        os.kill(child.pid, signal.SIGKILL)
        child.wait(timeout=30)
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
    assert child.returncode == -signal.SIGKILL
    killed_at = _last_step(ckpt)
    assert 3 <= killed_at < PARAMS["max_steps"]

    steps = {"n": 0}
    orig = neural._NeuralInpainter._train_step

    def counting(self, *a):
        steps["n"] += 1
        return orig(self, *a)

    monkeypatch.setattr(neural._NeuralInpainter, "_train_step", counting)
    resumed = UNetInpainter(**PARAMS, checkpoint_dir=ckpt).fit(_frames())
    assert steps["n"] == PARAMS["max_steps"] - killed_at  # continued, did not restart
    assert resumed.n_steps_ == full.n_steps_ == PARAMS["max_steps"]
    assert resumed.history_ == full.history_
    for k, v in full.model_.state_dict().items():
        assert np.array_equal(resumed.model_.state_dict()[k].numpy(), v.numpy()), k


@pytest.mark.parametrize("name", ["model.safetensors", "optimizer.safetensors", "training.json", "config.json"])
def test_truncated_checkpoint_is_a_clear_error_not_skipped(tmp_path, name):
    kw = {**PARAMS, "max_steps": 2}
    est = UNetInpainter(**kw, checkpoint_dir=tmp_path).fit(_frames())
    state = json.loads((est.run_dir_ / "state.json").read_text())
    path = est.run_dir_ / state["last"] / name
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(CheckpointError, match=name.replace(".", r"\.")):
        UNetInpainter(**kw, checkpoint_dir=tmp_path).fit(_frames())
