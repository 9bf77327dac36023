"""The training loop: interrupt + resume is the uninterrupted run bit for bit, for every
family trained step by step; a short real run must learn something about real KITTI depth."""

from __future__ import annotations

import json
import random

import numpy as np
import pytest
import torch
from joblib import Parallel, delayed

from estimators.learned import _training
from estimators.learned._neural import _NeuralInpainter
from estimators.learned import AutoencoderInpainter, UNetInpainter
from estimators.learned import PriorUNetInpainter
from inpaintenv.data import ArrayDataset
from inpaintenv.data.kitti import KittiDepth
from inpaintenv.masks import get_protocol
from inpaintenv.metrics import aggregate, frame_metrics
from training_helpers import gradient_frames

# -- resume: every family, every random stream ----------------------------------------------
#: Families whose fit runs the shared step loop (the blends fit in memory, without run checkpoints).
FAMILIES = {
    "unet": lambda **kw: UNetInpainter(width=4, depth=2, **kw),
    "autoencoder": lambda **kw: AutoencoderInpainter(width=4, depth=2, **kw),
    # The study networks' augmentation, drawn per (seed, epoch, index): a resume redraws it alike,
    # on either sampling path and with persistent loader workers.
    "unet-flip-jitter": lambda **kw: UNetInpainter(width=4, depth=2, flip=True, depth_jitter=1.5, **kw),
    "unet-flip-device": lambda **kw: UNetInpainter(width=4, depth=2, flip=True, sample_device="train", **kw),
    "autoencoder-flip-workers": lambda **kw: AutoencoderInpainter(width=4, depth=2, flip=True, num_workers=2, **kw),
    "prior-pixel": lambda **kw: PriorUNetInpainter(arch="pixel", width=4, levels=1, factor=2, **kw),
    "prior-unet": lambda **kw: PriorUNetInpainter(arch="unet", width=4, levels=1, factor=2, **kw),
}
RESUME = {"batch_size": 1, "epochs": 2, "max_steps": 6, "random_state": 0, "num_threads": 1, "device": "cpu",
          "checkpoint_every": 1}


_frames = gradient_frames


def _seed_globals(seed: int) -> None:
    np.random.seed(seed)
    random.seed(seed)
    torch.manual_seed(seed)


def _drawing_steps(monkeypatch, draws: list, crash_at: int | None = None) -> None:
    """Make every training step draw from the global NumPy, Python and torch streams (as
    user code inside a step may) and, optionally, the step ``crash_at`` raise (a crash)."""
    for klass in (_NeuralInpainter, PriorUNetInpainter):
        real = klass._train_step

        def step(self, *args, _real=real):
            if crash_at is not None and len(draws) == crash_at:
                raise KeyboardInterrupt("simulated crash")
            draws.append((np.random.random(), random.random(), torch.rand(1).item()))
            return _real(self, *args)

        monkeypatch.setattr(klass, "_train_step", step)


@pytest.mark.parametrize("family", list(FAMILIES))
def test_interrupted_and_resumed_run_is_the_uninterrupted_one(family, tmp_path, monkeypatch):
    make, frames = FAMILIES[family], _frames()
    full_draws: list = []
    with monkeypatch.context() as m:
        _drawing_steps(m, full_draws)
        _seed_globals(1)
        full = make(**RESUME, checkpoint_dir=tmp_path / "a").fit(frames)
    draws: list = []
    with monkeypatch.context() as m:
        _drawing_steps(m, draws, crash_at=4)  # mid-epoch 2 (3 frames, batch 1: 3 steps an epoch)
        _seed_globals(1)
        with pytest.raises(KeyboardInterrupt):
            make(**RESUME, checkpoint_dir=tmp_path / "b").fit(frames)
        (run,) = (tmp_path / "b").iterdir()
        assert json.loads((run / "state.json").read_text())["last"].startswith("ckpt-00000004")
    with monkeypatch.context() as m:
        _drawing_steps(m, draws)
        _seed_globals(2)  # another process: its global streams start elsewhere
        resumed = make(**RESUME, checkpoint_dir=tmp_path / "b").fit(frames)
    assert draws == full_draws  # the global streams continued from the checkpoint
    assert resumed.n_steps_ == full.n_steps_ == 6
    assert resumed.history_ == full.history_
    for key, value in full.model_.state_dict().items():
        assert torch.equal(resumed.model_.state_dict()[key], value), key


def test_unreadable_global_random_state_is_a_checkpoint_error():
    from estimators.learned._checkpoint import CheckpointError

    with pytest.raises(CheckpointError, match="global random state"):
        _training.set_global_rng_state({"torch": "zz", "numpy": [], "python": []})


# -- a short real run ---------------------------------------------------------------------
CROP = (64, 128)
TRAIN_DRIVE, HELD_OUT_DRIVE = "2011_09_26_drive_9001_sync", "2011_09_26_drive_9002_sync"


def _held_out_crops(frames: np.ndarray, seed: int = 1) -> np.ndarray:
    """4 random crops per frame from the lower image (where LiDAR ground truth lies)."""
    rng = np.random.default_rng(seed)
    h, w = frames.shape[1:]
    out = []
    for f in frames:
        for _ in range(4):
            top, left = rng.integers(h // 3, h - CROP[0]), rng.integers(0, w - CROP[1])
            out.append(f[top : top + CROP[0], left : left + CROP[1]])
    return np.stack(out)


def _fitted(estimator, train):
    return estimator.fit(train)


def _hole_rmse(pred: np.ndarray, gt: np.ndarray, hole: np.ndarray) -> float:
    # The untrained net's output, clipped at 0 m, is its estimate: scored as 0 m, as score() does.
    return aggregate(frame_metrics(pred, gt, hole, unfilled="zero"))["hole_rmse"]


@pytest.fixture(scope="module")
def short_run(kitti_root) -> dict[str, float]:
    """Hole RMSE (m) on held-out-drive crops after 300 steps: the study's U-Net untrained
    and trained, ours (frame depth scale + mask channels) trained, and constants."""
    train_all = KittiDepth(kitti_root, split="train", drives=[TRAIN_DRIVE])
    # Every 3rd frame, held in memory: the test measures learning, not PNG decoding.
    train = ArrayDataset(train_all.load_batch(range(0, len(train_all), 3)))
    held = KittiDepth(kitti_root, split="train", drives=[HELD_OUT_DRIVE])
    gt = _held_out_crops(held.load_batch(range(len(held))))
    hole = get_protocol("rect-v1").masks(CROP, 123, range(len(gt)))
    x = np.where(hole, np.nan, gt).astype(np.float32)

    params = {"width": 8, "depth": 3, "crop": CROP, "batch_size": 4, "epochs": 10_000, "random_state": 0, "num_threads": 1}
    untrained = UNetInpainter(**params, max_steps=1, lr=1e-12).fit(train)
    # The two 300-step trainings, one thread each, in two worker processes: what one thread
    # each would give in this process, in half the time on two cores.
    study, ours = Parallel(n_jobs=2, backend="loky")(delayed(_fitted)(estimator, train) for estimator in (
        UNetInpainter(**params, max_steps=300),
        UNetInpainter(**params, max_steps=300, depth_scale="frame", input_mask=True)))
    train_gt = np.asarray(train)
    constant = np.where(x > 0, x, train_gt[train_gt > 0].mean())  # the best constant on training data
    # Not a constant predictor but the reference for depth_scale="frame": each crop's own mean.
    crop_mean = np.where(x > 0, x, np.array([f[f > 0].mean() for f in np.nan_to_num(x)])[:, None, None])
    result = {
        "untrained": _hole_rmse(untrained.predict(x), gt, hole),
        "study": _hole_rmse(study.predict(x), gt, hole),
        "ours": _hole_rmse(ours.predict(x), gt, hole),
        "constant": _hole_rmse(constant, gt, hole),
        "crop_mean": _hole_rmse(crop_mean, gt, hole),
        "first_epoch_loss": study.history_["epoch_loss"][0],
        "last_epoch_loss": study.history_["epoch_loss"][-1],
    }
    print("hole RMSE on held-out crops (m):", {k: round(v, 3) for k, v in result.items()})
    return result


@pytest.mark.slow
@pytest.mark.kitti
def test_short_training_learns(short_run):
    """The study's recipe (depth-only input, fixed 80 m scale) learns: error and loss fall."""
    assert short_run["study"] < 0.7 * short_run["untrained"]
    assert short_run["last_epoch_loss"] < 0.5 * short_run["first_epoch_loss"]


@pytest.mark.slow
@pytest.mark.kitti
def test_short_training_beats_constant(short_run):
    """With the frame depth scale, 300 steps beat the best constant depth clearly.

    (The study's fixed scale does not yet at this budget -- 7.8 m vs 7.0 m when this
    was written -- because GroupNorm discards the level of a depth-only input; see
    docs/neural.md.)
    """
    assert short_run["ours"] < 0.8 * short_run["constant"]
    assert short_run["ours"] < 0.5 * short_run["untrained"]
