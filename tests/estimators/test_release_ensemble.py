"""The shipped ensemble release kitti-ensemble-v1 (MeanEnsembleInpainter): the default learned method
(``pretrained`` and its former names), made by the ``ensemble-kitti`` preset, with its provenance;
it predicts full frames of every KITTI frame size, keeps measurements, and beats every classical
method on the shared slice's official frames it never saw (the ``val`` drive)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from param_values import param_values
from release_checks import (
    FRAME_SHAPES,
    check_beats_every_classical_method,
    check_full_frame,
    class_in_fresh_process,
)

from estimators.blend import BlendInpainter
from estimators.context_blend import ContextBlendInpainter
from estimators.ensemble import DEFAULT_ENSEMBLE, MeanEnsembleInpainter
from estimators.learned._checkpoint import PRETRAINED_DIR
from estimators.learned.releases import DEFAULT_RELEASE, load_release
from estimators.presets import PRESETS
from inpaintenv.registry import make_method


@pytest.fixture(scope="module")
def release() -> MeanEnsembleInpainter:
    return load_release()


def test_default_learned_method_is_this_release(release):
    assert DEFAULT_RELEASE == DEFAULT_ENSEMBLE == "kitti-ensemble-v1"
    assert isinstance(release, MeanEnsembleInpainter) and release.shares_features_
    context, blend = release.named_estimators_["context"], release.named_estimators_["blend"]
    assert isinstance(context, ContextBlendInpainter) and context.n_members == 2 and context.tta is False
    assert isinstance(blend, BlendInpainter) and blend.tta is False
    for name in ("pretrained", "blend-pretrained", "unet-pretrained", "kitti-ensemble-v1"):
        est = make_method(name)
        assert isinstance(est, MeanEnsembleInpainter)
        assert param_values(est) == param_values(release)
    assert isinstance(make_method("kitti-context-v3"), ContextBlendInpainter)  # the former default, by name


def test_recipe_of_the_preset_made_these_weights():
    # `inpaintenv train --preset ensemble-kitti` made the release: each member's parameters.
    _, params, _ = PRESETS["ensemble-kitti"]
    shipped = {m["name"]: m["config"]["params"]
               for m in json.loads((PRETRAINED_DIR / "kitti-ensemble-v1.json").read_text())["members"]}
    assert list(shipped) == [name for name, _ in params["estimators"]]
    for name, member in params["estimators"]:
        for key, value in member.get_params().items():
            if key != "verbose":  # progress printing, set by `inpaintenv train --quiet`
                assert shipped[name][key] == (list(value) if isinstance(value, tuple) else value), (name, key)


def test_context_member_is_kitti_context_v3_array_for_array():
    # The ensemble preset's context member is context-kitti-draws, random_state 0, on the same
    # 511 frames as kitti-context-v3: the two training runs gave the same weights, which is
    # what the card's reproduction claim rests on.
    from safetensors.numpy import load_file

    ensemble = load_file(PRETRAINED_DIR / "kitti-ensemble-v1.safetensors")
    context_v3 = load_file(PRETRAINED_DIR / "kitti-context-v3.safetensors")
    assert context_v3 and all(np.array_equal(ensemble[f"context.{key}"], value) for key, value in context_v3.items())
    assert {key for key in ensemble if key.startswith("context.")} == {f"context.{key}" for key in context_v3}


def test_release_records_its_training_drives_and_machine(release):
    config = json.loads((PRETRAINED_DIR / "kitti-ensemble-v1.json").read_text())
    drives = config["training_drives"]
    assert release.training_drives_ == drives and len(drives) >= 3
    assert all(m["config"]["training_drives"] == drives for m in config["members"])  # both on the same frames
    assert not any(d.startswith("2011_10_03_drive_91") for d in drives)  # the val drive stays unseen
    env = config["environment"]
    assert {"python", "cpu_count"} <= set(env) and "torch" in json.dumps(env)


@pytest.mark.parametrize("shape", FRAME_SHAPES)
def test_full_frame_of_every_size_keeps_measurements_and_is_fast(release, shape):
    check_full_frame(release, shape)


@pytest.mark.kitti
@pytest.mark.slow
def test_beats_every_classical_method_on_the_unseen_val_drive(kitti_root, release):
    """The shared slice's ``val`` drive (official KITTI maps) was never trained or selected
    on: mean hole RMSE over five mask seeds below that of every method of estimators.classical."""
    from inpaintenv.data import KittiDepth

    check_beats_every_classical_method(release, DEFAULT_RELEASE, KittiDepth(kitti_root, split="val"), [0, 1, 2, 3, 4])


def test_loads_in_a_fresh_process_by_registry_name():
    """A fresh interpreter (as the CLI is) finds the release's class without importing it first."""
    assert class_in_fresh_process("pretrained") == "MeanEnsembleInpainter"
