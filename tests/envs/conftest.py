"""Small semi-dense frames for the env tests (fast; no data source needed)."""

from __future__ import annotations

import numpy as np
import pytest

from inpaintenv.data import ArrayDataset

SHAPE = (24, 40)


def make_frames(n: int = 5, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    frames = (rng.random((n, *SHAPE)) * 40.0 + 2.0).astype(np.float32)
    frames[rng.random(frames.shape) < 0.4] = 0.0
    return frames


@pytest.fixture
def frame_factory():
    """``make_frames(n, seed)``: random semi-dense ``(n, 24, 40)`` frames."""
    return make_frames


@pytest.fixture
def frames() -> np.ndarray:
    return make_frames()


@pytest.fixture
def dataset(frames) -> ArrayDataset:
    return ArrayDataset(frames, groups=["d0", "d0", "d1", "d1", "d2"])
