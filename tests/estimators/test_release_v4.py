"""The former default release (kitti-rect-v4, a BlendInpainter; loadable by name): loads, is fast, keeps
measurements, matches its training recipe, and beats the classical methods on the real
drive it never saw (2011_09_26_drive_9002_sync of the shared KITTI slice)."""

from __future__ import annotations

import json

import pytest
from release_checks import check_beats_every_classical_method, check_full_frame

from estimators.blend import DEFAULT_BLEND, PRETRAINED_DIR, BlendInpainter
from estimators.presets import PRESETS
from inpaintenv.registry import make_method


@pytest.fixture(scope="module")
def release() -> BlendInpainter:
    return BlendInpainter.pretrained()


def test_release_loads_by_name(release):
    assert DEFAULT_BLEND == "kitti-rect-v4"  # BlendInpainter.pretrained()'s default
    assert make_method("kitti-rect-v4").get_params() == release.get_params()


def test_recipe_of_the_preset_made_these_weights():
    # `inpaintenv train --preset blend-kitti` reproduces the release: same parameters.
    _, params, _ = PRESETS["blend-kitti"]
    shipped = json.loads((PRETRAINED_DIR / f"{DEFAULT_BLEND}.json").read_text())["params"]
    for key, value in params.items():
        assert shipped[key] == (list(value) if isinstance(value, tuple) else value), key


def test_full_frame_prediction_keeps_measurements_and_is_fast(release):
    check_full_frame(release)


@pytest.mark.kitti
@pytest.mark.slow
def test_beats_every_classical_method_on_its_held_out_drive(kitti_root):
    """Drive 2011_09_26_drive_9002_sync was left out of the release's training (and of
    recipe selection): mean hole RMSE below that of every method of estimators.classical."""
    from inpaintenv.data import KittiDepth

    held_out = KittiDepth(kitti_root, split="train", drives=["2011_09_26_drive_9002_sync"])
    check_beats_every_classical_method(BlendInpainter.pretrained(), "kitti-rect-v4", held_out, [0])
