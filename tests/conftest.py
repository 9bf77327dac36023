"""Shared fixtures: the real KITTI slice (skipped when absent) and small synthetic frames."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]


def find_kitti_root() -> Path | None:
    """``$INPAINTENV_KITTI_ROOT``, else ``../shared/kitti`` beside the project root."""
    env = os.environ.get("INPAINTENV_KITTI_ROOT")
    candidates = [Path(env)] if env else []
    candidates.append(REPO_ROOT.parent / "shared" / "kitti")
    for c in candidates:
        if (c / "train").is_dir() or (c / "val").is_dir():
            return c
    return None


@pytest.fixture(scope="session")
def kitti_root() -> Path:
    """Root of the real KITTI depth-completion slice; skips the test when absent."""
    root = find_kitti_root()
    if root is None:
        pytest.skip(
            "real KITTI slice not found: set INPAINTENV_KITTI_ROOT or place it at "
            "../shared/kitti beside the project root"
        )
    return root


def layout_frames(root: Path, split: str, camera: str = "image_02") -> dict[str, int]:
    """Ground-truth PNGs per drive, counted from the official layout on disk.

    Tests compare the loader against this count instead of pinning the slice's size,
    which grows when more real frames are found.
    """
    counts = {}
    for drive in sorted((Path(root) / split).glob("*_sync")):
        n = len(list((drive / "proj_depth" / "groundtruth" / camera).glob("*.png")))
        if n:
            counts[drive.name] = n
    return counts


@pytest.fixture(scope="session")
def kitti_layout(kitti_root):
    """``kitti_layout(split)``: ground-truth frames per drive of the real slice, from disk."""
    return lambda split, camera="image_02": layout_frames(kitti_root, split, camera)


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(0)


@pytest.fixture
def small_gt(rng) -> np.ndarray:
    """Three 32×48 semi-dense depth maps that vary smoothly along rows (metres)."""
    rows = np.linspace(5.0, 40.0, 32, dtype=np.float32)[:, None]
    cols = np.linspace(0.0, 3.0, 48, dtype=np.float32)[None, :]
    base = rows + cols
    frames = np.stack([base + k for k in range(3)]).astype(np.float32)
    frames[rng.random(frames.shape) < 0.3] = 0.0  # LiDAR gaps
    return frames
