"""The shipped ensemble release kitti-ensemble-v1 (MeanEnsembleInpainter): the default learned method
(``pretrained`` and its former names), made by the ``ensemble-kitti`` preset, with its provenance;
it predicts full frames of every KITTI frame size, keeps measurements, and beats every classical
method on the shared slice's official frames it never saw (the ``val`` drive)."""

from __future__ import annotations

import json
import time

import numpy as np
import pytest
from param_values import param_values

from estimators.blend import BlendInpainter
from estimators.context_blend import ContextBlendInpainter
from estimators.ensemble import DEFAULT_ENSEMBLE, MeanEnsembleInpainter
from estimators.learned._checkpoint import PRETRAINED_DIR
from estimators.learned.releases import DEFAULT_RELEASE, load_release
from estimators.presets import PRESETS
from inpaintenv.data import SyntheticStreets
from inpaintenv.masks import get_protocol
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


@pytest.mark.parametrize("shape", [(352, 1216), (375, 1242), (370, 1226), (376, 1241), (376, 1408)])
def test_full_frame_of_every_size_keeps_measurements_and_is_fast(release, shape):
    gt = SyntheticStreets(n=1, seed=3, frame_shape=shape)[0]
    hole = get_protocol("rect-v1").mask(gt.shape, 0, 0)
    x = np.where(hole, np.nan, gt).astype(np.float32)
    release.predict(x)  # warm-up
    start = time.perf_counter()
    out = release.predict(x)
    seconds = time.perf_counter() - start
    assert out.shape == x.shape and np.isfinite(out).all() and (out[hole] > 0).all()
    measured = (gt > 0) & ~hole
    np.testing.assert_array_equal(out[measured], gt[measured])
    # The goal is 0.3 s on 2 idle cores (benchmarks/bench_blend.py); a loaded CI
    # machine gets 10x that before this order-of-magnitude check fails.
    assert seconds < 3.0, f"predict took {seconds:.2f} s on a {shape} frame"


@pytest.mark.kitti
@pytest.mark.slow
def test_beats_every_classical_method_on_the_unseen_val_drive(kitti_root, release):
    """The shared slice's ``val`` drive (official KITTI maps) was never trained or selected
    on: mean hole RMSE over five mask seeds below that of every method of estimators.classical."""
    from inpaintenv.benchmark.suites import CLASSICAL, STUDY_CLASSICAL
    from inpaintenv.data import KittiDepth
    from inpaintenv.evaluate import evaluate
    from inpaintenv.registry import unfilled_policy

    held_out = KittiDepth(kitti_root, split="val")
    seeds = [0, 1, 2, 3, 4]

    def mean_hole_rmse(method, unfilled: str = "error") -> float:
        rows = evaluate(method, held_out, "rect-v1", seeds, progress=False, unfilled=unfilled).rows
        return float(np.nanmean([r["hole_rmse"] for r in rows]))

    learned = mean_hole_rmse(release)
    classical = {name: mean_hole_rmse(make_method(name), unfilled_policy(name)) for name in CLASSICAL + STUDY_CLASSICAL}
    best = min(classical, key=classical.get)
    assert learned < classical[best], f"{DEFAULT_RELEASE} {learned:.2f} m vs {best} {classical[best]:.2f} m"


def test_loads_in_a_fresh_process_by_registry_name():
    """A fresh interpreter (as the CLI is) finds the release's class without importing it first."""
    import subprocess
    import sys

    code = "from inpaintenv.registry import make_method; print(type(make_method('pretrained')).__name__)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "MeanEnsembleInpainter"
