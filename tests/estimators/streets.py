"""Small ground-plane-like frames for the learned blends' tests (imported by test modules)."""

from __future__ import annotations

import numpy as np


def streets(n: int = 6, h: int = 40, w: int = 96, seed: int = 0) -> np.ndarray:
    """Ground-plane-like frames: inverse depth linear in the row, LiDAR-like gaps (40 % missing)."""
    rng = np.random.default_rng(seed)
    rows = np.arange(h, dtype=np.float32)[:, None]
    frames = []
    for k in range(n):
        depth = 400.0 / (rows + 8.0 + 2 * k) + 0.02 * np.arange(w, dtype=np.float32)[None]
        depth = np.broadcast_to(depth, (h, w)).copy()
        depth[rng.random((h, w)) < 0.4] = 0.0
        frames.append(depth)
    return np.stack(frames).astype(np.float32)
