"""Helpers shared by the learned estimators' training tests (imported by test modules)."""

from __future__ import annotations

import numpy as np


def gradient_frames() -> np.ndarray:
    """Three 32x48 frames: depth rising down the rows and across, 30 % of pixels unmeasured."""
    rng = np.random.default_rng(0)
    rows = np.linspace(5.0, 40.0, 32, dtype=np.float32)[:, None]
    frames = np.stack([rows + np.linspace(0.0, 3.0, 48, dtype=np.float32)[None, :] + k for k in range(3)])
    frames[rng.random(frames.shape) < 0.3] = 0.0
    return frames.astype(np.float32)


def interrupt_after(monkeypatch, cls: type, n_steps: int) -> None:
    """Make the ``n_steps + 1``-th training step of a ``cls`` fit raise (a simulated crash)."""
    orig = cls._train_step
    calls = {"n": 0}

    def step(self, *args):
        if calls["n"] == n_steps:
            raise KeyboardInterrupt("simulated crash")
        calls["n"] += 1
        return orig(self, *args)

    monkeypatch.setattr(cls, "_train_step", step)
