"""A short real training run: the U-Net must learn something about real KITTI depth."""

from __future__ import annotations

import numpy as np
import pytest

from estimators.neural import UNetInpainter
from inpaintenv.data import ArrayDataset
from inpaintenv.data.kitti import KittiDepth
from inpaintenv.masks import get_protocol
from inpaintenv.metrics import aggregate, frame_metrics

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
    study = UNetInpainter(**params, max_steps=300).fit(train)
    ours = UNetInpainter(**params, max_steps=300, depth_scale="frame", input_mask=True).fit(train)
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
