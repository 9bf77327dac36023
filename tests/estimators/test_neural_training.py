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
    return aggregate(frame_metrics(pred, gt, hole))["hole_rmse"]


@pytest.fixture(scope="module")
def short_run(kitti_root) -> dict[str, float]:
    """Hole RMSE (m) on held-out-drive crops: untrained, 300-step trained, best constant."""
    train_all = KittiDepth(kitti_root, split="train", drives=[TRAIN_DRIVE])
    # Every 3rd frame, held in memory: the test measures learning, not PNG decoding.
    train = ArrayDataset(train_all.load_batch(range(0, len(train_all), 3)))
    held = KittiDepth(kitti_root, split="train", drives=[HELD_OUT_DRIVE])
    gt = _held_out_crops(held.load_batch(range(len(held))))
    hole = get_protocol("rect-v1").masks(CROP, 123, range(len(gt)))
    x = np.where(hole, np.nan, gt).astype(np.float32)

    params = {"width": 8, "depth": 3, "crop": CROP, "batch_size": 4, "epochs": 10_000, "random_state": 0, "num_threads": 1}
    untrained = UNetInpainter(**params, max_steps=1, lr=1e-12).fit(train)
    trained = UNetInpainter(**params, max_steps=300).fit(train)
    train_gt = np.asarray(train)
    constant = np.where(x > 0, x, train_gt[train_gt > 0].mean())  # the best constant on training data
    result = {
        "untrained": _hole_rmse(untrained.predict(x), gt, hole),
        "trained": _hole_rmse(trained.predict(x), gt, hole),
        "constant": _hole_rmse(constant, gt, hole),
        "first_epoch_loss": trained.history_["epoch_loss"][0],
        "last_epoch_loss": trained.history_["epoch_loss"][-1],
    }
    print("hole RMSE on held-out crops (m):", {k: round(v, 3) for k, v in result.items()})
    return result


@pytest.mark.slow
@pytest.mark.kitti
def test_short_training_learns(short_run):
    assert short_run["trained"] < 0.7 * short_run["untrained"]
    assert short_run["last_epoch_loss"] < 0.5 * short_run["first_epoch_loss"]


@pytest.mark.slow
@pytest.mark.kitti
@pytest.mark.xfail(
    strict=False,
    reason="known gap: 300 CPU steps of the study's recipe (depth-only input, GroupNorm) "
    "do not yet beat the training-mean constant on held-out crops (7.8 m vs 7.0 m, "
    "16:58 UTC 2026-11-25); issue 8 is about closing it",
)
def test_short_training_beats_constant(short_run):
    assert short_run["trained"] < 0.95 * short_run["constant"]
