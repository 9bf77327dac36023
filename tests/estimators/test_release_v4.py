"""The former default release (kitti-rect-v4, a BlendInpainter; loadable by name): loads, is fast, keeps
measurements, matches its training recipe, and beats the classical methods on the real
drive it never saw (2011_09_26_drive_9002_sync of the shared KITTI slice)."""

from __future__ import annotations

import json
import time

import numpy as np
import pytest

from estimators.blend import DEFAULT_BLEND, PRETRAINED_DIR, BlendInpainter
from estimators.presets import PRESETS
from inpaintenv.data import SyntheticStreets
from inpaintenv.masks import get_protocol
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
    gt = SyntheticStreets(n=1, seed=3)[0]
    assert gt.shape == (352, 1216)
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
    assert seconds < 3.0, f"predict took {seconds:.2f} s on a 352x1216 frame"


@pytest.mark.kitti
@pytest.mark.slow
def test_beats_every_classical_method_on_its_held_out_drive(kitti_root):
    """Drive 2011_09_26_drive_9002_sync was left out of the release's training (and of
    recipe selection): mean hole RMSE below that of every method of estimators.classical."""
    from inpaintenv.benchmark.suites import CLASSICAL, STUDY_CLASSICAL
    from inpaintenv.data import KittiDepth
    from inpaintenv.evaluate import evaluate

    held_out = KittiDepth(kitti_root, split="train", drives=["2011_09_26_drive_9002_sync"])

    from inpaintenv.registry import unfilled_policy

    def mean_hole_rmse(method, unfilled: str = "error") -> float:
        rows = evaluate(method, held_out, "rect-v1", [0], progress=False, unfilled=unfilled).rows
        return float(np.nanmean([r["hole_rmse"] for r in rows]))

    learned = mean_hole_rmse(BlendInpainter.pretrained())
    # Each scored as the benchmark scores it (the study's hole-only fills: 0 m as 0 m).
    classical = {name: mean_hole_rmse(make_method(name), unfilled_policy(name)) for name in CLASSICAL + STUDY_CLASSICAL}
    best = min(classical, key=classical.get)
    assert learned < classical[best], f"kitti-rect-v4 {learned:.2f} m vs {best} {classical[best]:.2f} m"
