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


#: Found once, before any test runs: the fixture below removes the variable from each test.
KITTI_ROOT = find_kitti_root()


def find_kitti_raw_root() -> Path | None:
    """The real LiDAR scans with their calibration (``../shared/kitti-raw``, see its README).

    ``$INPAINTENV_KITTI_RAW_ROOT``, else ``kitti-raw`` beside the KITTI root found above.
    """
    env = os.environ.get("INPAINTENV_KITTI_RAW_ROOT")
    candidates = [Path(env)] if env else []
    candidates += [KITTI_ROOT.parent / "kitti-raw"] if KITTI_ROOT is not None else []
    return next((c for c in candidates if (c / "2011_09_26").is_dir()), None)


KITTI_RAW_ROOT = find_kitti_raw_root()


@pytest.fixture(autouse=True, scope="session")
def _no_kitti_root_variable():
    """Every test (and every module- or session-scoped fixture) runs without ``$INPAINTENV_KITTI_ROOT``.

    The CLI reads the variable when ``--kitti-root`` is absent, so a test running
    ``main([...])`` on synthetic data would score KITTI wherever the variable is set (CI
    sets it). Tests that need real frames pass the ``kitti_root`` fixture's path
    explicitly; tests of the variable itself set it with ``monkeypatch.setenv``. The
    suite therefore runs the same with and without the variable (subprocesses too:
    the variable is removed from ``os.environ``, which they inherit). Session-scoped, so it
    is gone before any fixture runs a command, and with its own MonkeyPatch, so that a
    test's ``monkeypatch.undo()`` does not bring the variable back.
    """
    with pytest.MonkeyPatch.context() as mp:
        mp.delenv("INPAINTENV_KITTI_ROOT", raising=False)
        yield


@pytest.fixture(scope="session")
def kitti_root() -> Path:
    """Root of the real KITTI depth-completion slice; skips the test when absent."""
    root = KITTI_ROOT
    if root is None:
        pytest.skip(
            "real KITTI slice not found: set INPAINTENV_KITTI_ROOT or place it at "
            "../shared/kitti beside the project root"
        )
    return root


@pytest.fixture(scope="session")
def kitti_raw_root() -> Path:
    """Root of the real LiDAR scans (raw, odometry, KITTI-360 layouts); skips the test when absent."""
    if KITTI_RAW_ROOT is None:
        pytest.skip(
            "real LiDAR scans not found: set INPAINTENV_KITTI_RAW_ROOT or place kitti-raw beside the KITTI slice"
        )
    return KITTI_RAW_ROOT


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


#: ``INPAINTENV_GPU_TESTS_ON_CPU=1`` runs the tests marked ``gpu`` on the CPU even where a
#: CUDA device is present; without one they always run on the CPU, so the main suite
#: exercises their code path on every machine.
GPU_TESTS_ON_CPU = "INPAINTENV_GPU_TESTS_ON_CPU"


def gpu_test_device() -> str:
    """The device of the tests marked ``gpu``: "cuda" when present and not forced off, else "cpu"."""
    if os.environ.get(GPU_TESTS_ON_CPU) == "1":
        return "cpu"
    import torch  # only once a gpu-marked test runs: most runs never pay the import here

    return "cuda" if torch.cuda.is_available() else "cpu"


@pytest.fixture(scope="session")
def gpu_device():
    """``torch.device`` the tests marked ``gpu`` run on: ``cuda`` on a GPU, else (or when forced) ``cpu``."""
    import torch

    return torch.device(gpu_test_device())
