"""Fixtures of the experiment-script tests.

A script of experiments/ loaded as a module (the folder is not a package), and a tiny KITTI tree.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

EXPERIMENTS = Path(__file__).resolve().parents[2] / "experiments"


@pytest.fixture(scope="session")
def load_experiment():
    """``load_experiment("nested_mean")``: ``experiments/nested_mean.py`` as a module."""

    def load(name: str) -> ModuleType:
        spec = importlib.util.spec_from_file_location(name, EXPERIMENTS / f"{name}.py")
        module = importlib.util.module_from_spec(spec)
        sys.path.insert(0, str(EXPERIMENTS))  # a script imports its siblings, as when run from there
        try:
            spec.loader.exec_module(module)
        finally:
            sys.path.remove(str(EXPERIMENTS))
        return module

    return load


@pytest.fixture(scope="session")
def tiny_kitti(tmp_path_factory):
    """Three train drives and one val drive of one frame each, in the KITTI layout."""
    from inpaintenv.data.io import write_depth_png

    root = tmp_path_factory.mktemp("kitti")
    rng = np.random.default_rng(0)
    for split, drive in [("train", f"2011_09_26_drive_900{k}_sync") for k in (1, 2, 4)] + [
            ("val", "2011_10_03_drive_9101_sync")]:
        folder = root / split / drive / "proj_depth" / "groundtruth" / "image_02"
        folder.mkdir(parents=True)
        depth = np.where(rng.random((375, 1242)) < 0.3, 5.0 + 20 * rng.random((375, 1242)), 0.0)
        write_depth_png(folder / "0000000005.png", depth.astype(np.float32))
    return root
