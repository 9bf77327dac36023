"""Fixtures of the experiment-script tests.

A script of experiments/ loaded as a module (the folder is not a package), a tiny KITTI tree,
and tiny trained blend models shared by the tests that only need some saved model.
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


@pytest.fixture(scope="session")
def tiny_models(tmp_path_factory) -> dict[str, Path]:
    """Saved tiny learned models, each trained once per session: ``{"blend", "blend-1", "context"} -> folder``.

    Two blends (seeds 0 and 1) and a context blend, each trained for one epoch on three
    48x128 synthetic frames: the tests that use them check what a script does with saved
    models, not what the models learned. Tests copy or load them; none writes into them.
    """
    from estimators.learned import BlendInpainter, ContextBlendInpainter
    from inpaintenv.data import SyntheticStreets

    root = tmp_path_factory.mktemp("models")
    frames = SyntheticStreets(n=3, frame_shape=(48, 128))
    small = dict(epochs=1, masks_per_frame=1, keep=(1.0,), pixels_per_frame=100, num_threads=1)
    models = {"blend": BlendInpainter(**small, width=4, layers=1, batch_pixels=64),
              "blend-1": BlendInpainter(**small, width=4, layers=1, batch_pixels=64, random_state=1),
              "context": ContextBlendInpainter(**small, n_context=2, context_widths=(4, 4), width=4, layers=1,
                                               batch_frames=2, batch_pixels=32)}
    return {name: Path(model.fit(frames).save(root / name)) for name, model in models.items()}
