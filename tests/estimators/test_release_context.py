"""The shipped context releases (ContextBlendInpainter): kitti-context-v3 (two networks, each
trained on its own samples, averaged; the default until kitti-ensemble-v1, whose context member
it is), kitti-context-v2 and kitti-context-v1 load by name;
each matches its training recipe and records its provenance; the default predicts full
frames of every KITTI frame size, keeps measurements, and beats every classical method on
the shared slice's official frames it never saw (the ``val`` drive)."""

from __future__ import annotations

import json
import time

import numpy as np
import pytest

from estimators.context_blend import DEFAULT_CONTEXT_BLEND, ContextBlendInpainter
from estimators.presets import PRESETS
from estimators.learned.releases import DEFAULT_RELEASE, load_release
from estimators.learned._checkpoint import PRETRAINED_DIR
from inpaintenv.data import SyntheticStreets
from inpaintenv.masks import get_protocol
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
    assert learned < classical[best], f"kitti-context-v3 {learned:.2f} m vs {best} {classical[best]:.2f} m"


def test_loads_in_a_fresh_process_by_registry_name():
    """A fresh interpreter (as the CLI is) finds the release's class without importing it first."""
    import subprocess
    import sys

    code = "from inpaintenv.registry import make_method; print(type(make_method('kitti-context-v3')).__name__)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "ContextBlendInpainter"
