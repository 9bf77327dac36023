"""The shipped context releases (ContextBlendInpainter): kitti-context-v3 (two networks, each
trained on its own samples, averaged; the default until kitti-ensemble-v1, whose context member
it is), kitti-context-v2 and kitti-context-v1 load by name;
each matches its training recipe and records its provenance; the default predicts full
frames of every KITTI frame size, keeps measurements, and beats every classical method on
the shared slice's official frames it never saw (the ``val`` drive)."""

from __future__ import annotations

import json

import pytest
from release_checks import (
    FRAME_SHAPES,
    check_beats_every_classical_method,
    check_full_frame,
    class_in_fresh_process,
)

from estimators.context_blend import DEFAULT_CONTEXT_BLEND, ContextBlendInpainter
from estimators.learned._checkpoint import PRETRAINED_DIR
from estimators.learned.releases import DEFAULT_RELEASE, load_release
from estimators.presets import PRESETS
from inpaintenv.registry import make_method


@pytest.fixture(scope="module")
def release() -> ContextBlendInpainter:
    return load_release("kitti-context-v3")


def test_the_releases_load_by_name(release):
    assert DEFAULT_CONTEXT_BLEND == "kitti-context-v3" and DEFAULT_RELEASE != DEFAULT_CONTEXT_BLEND
    assert isinstance(release, ContextBlendInpainter)
    assert release.n_members == len(release._networks()) == 2 and release.tta is False
    assert release.member_samples == "own"
    assert make_method("kitti-context-v3").get_params() == release.get_params()
    assert ContextBlendInpainter.pretrained().get_params() == release.get_params()
    former = make_method("kitti-context-v2")  # the former default: two networks on one draw
    assert former.n_members == len(former._networks()) == 2 and former.member_samples == "shared"
    first = make_method("kitti-context-v1")  # one network, loads by name
    assert first.n_members == len(first._networks()) == 1 and first.tta is True
    with pytest.raises(KeyError, match="no shipped release 'nope'; shipped: "):
        load_release("nope")


@pytest.mark.parametrize("name, preset", [("kitti-context-v3", "context-kitti-draws"),
                                          ("kitti-context-v2", "context-kitti-ensemble"),
                                          ("kitti-context-v1", "context-kitti")])
def test_recipe_of_the_preset_made_these_weights(name, preset):
    # `inpaintenv train --preset <preset>` made the release: same parameters.
    _, params, _ = PRESETS[preset]
    shipped = json.loads((PRETRAINED_DIR / f"{name}.json").read_text())["params"]
    for key, value in params.items():
        assert shipped.get(key, 1 if key == "n_members" else None) == (
            list(value) if isinstance(value, tuple) else value), key


@pytest.mark.parametrize("name", ["kitti-context-v3", "kitti-context-v2", "kitti-context-v1"])
def test_release_records_its_training_drives_and_machine(name):
    config = json.loads((PRETRAINED_DIR / f"{name}.json").read_text())
    drives = config["training_drives"]
    assert load_release(name).training_drives_ == drives and len(drives) >= 3
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

    check_beats_every_classical_method(release, "kitti-context-v3", KittiDepth(kitti_root, split="val"), [0, 1, 2, 3, 4])


def test_loads_in_a_fresh_process_by_registry_name():
    """A fresh interpreter (as the CLI is) finds the release's class without importing it first."""
    assert class_in_fresh_process("kitti-context-v3") == "ContextBlendInpainter"
