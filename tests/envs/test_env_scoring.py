"""The env's fast scoring path: same numbers as the full-frame metrics, one gather per episode.

``step`` scores with the :class:`~inpaintenv.metrics.ScoredPixels` built at ``reset``
instead of calling :func:`~inpaintenv.metrics.frame_metrics` on the whole frame
(``docs/env.md``, "Speed"). These tests pin the numbers to an independent reference
(the boolean-mask code path the env used before) and guard the design.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import inpaintenv  # noqa: F401  (registers the env ids)
import inpaintenv.envs.inpaint as inpaint_module
import inpaintenv.metrics._depth as metrics_module  # where frame_metrics is looked up
from inpaintenv.data import ArrayDataset
from inpaintenv.envs import DepthInpaintEnv
from inpaintenv.metrics import ScoredPixels, frame_metrics

_BENCHMARKS = Path(__file__).resolve().parents[2] / "perf"
METRIC_KEYS = [f"{r}_{m}" for r in ("hole", "all") for m in ("rmse", "mae", "irmse", "imae", "psnr", "count")]


def boolean_mask_metrics(pred, gt, hole, max_depth=80.0):
    """One frame's metrics the direct way (boolean gathers, float64), as the env scored before."""
    valid = gt > 0
    p = pred[valid].astype(np.float64)
    g = gt[valid].astype(np.float64)
    err = p - g
    inv_err = 1000.0 / np.maximum(p, 0.1) - 1000.0 / g
    out = {}
    for region, sel in (("hole", hole[valid]), ("all", np.ones(g.size, bool))):
        e, ie, n = err[sel], inv_err[sel], int(sel.sum())
        rmse = float(np.sqrt((e * e).sum() / n)) if n else np.nan
        out[f"{region}_rmse"] = rmse
        out[f"{region}_mae"] = float(np.abs(e).sum() / n) if n else np.nan
        out[f"{region}_irmse"] = float(np.sqrt((ie * ie).sum() / n)) if n else np.nan
        out[f"{region}_imae"] = float(np.abs(ie).sum() / n) if n else np.nan
        out[f"{region}_psnr"] = float(20 * np.log10(max_depth / max(rmse, 1e-6))) if n else np.nan
        out[f"{region}_count"] = n
    return out


def assert_same_metrics(info, want):
    for key in METRIC_KEYS:
        assert info[key] == pytest.approx(want[key], rel=1e-9, abs=0.0), key


def _actions(obs, gt, rng):
    """The observation itself, a noisy full reconstruction, and ground truth (perfect)."""
    hole = obs["hole"].astype(bool)
    noisy = np.abs(gt + rng.normal(0.0, 2.0, gt.shape)).astype(np.float32)
    return [obs["depth"], np.where(hole, noisy, obs["depth"]).astype(np.float32), noisy, gt]


def _check_episodes(env, frames, n_episodes, max_depth=80.0):
    """Score several actions per served (frame, mask) against both references."""
    rng = np.random.default_rng(0)
    obs, info = env.reset(seed=0)
    for _ in range(n_episodes):
        same = {"index": info["index"], "mask_seed": info["mask_seed"]}
        gt, hole = frames[info["index"]], obs["hole"].astype(bool)
        for action in _actions(obs, gt, rng):
            env.reset(options=same)  # the same frame and mask again
            _, reward, _, _, step_info = env.step(action)
            assert_same_metrics(step_info, boolean_mask_metrics(action, gt, hole, max_depth))
            full = frame_metrics(action, gt, hole, max_depth=max_depth, unfilled="zero")
            assert_same_metrics(step_info, {k: float(v) for k, v in full.items()})
            assert reward == -step_info["hole_rmse"]
        obs, info = env.reset()


@pytest.mark.parametrize("max_depth", [80.0, 120.0])
def test_step_metrics_match_the_boolean_mask_reference(frame_factory, max_depth):
    frames = frame_factory(4, seed=3)
    # unfilled="zero": the observation itself (holes at 0 m) is one of the actions scored.
    env = gym.make("inpaintenv/DepthInpaint-v0", dataset=ArrayDataset(frames), max_depth=max_depth, unfilled="zero")
    _check_episodes(env, frames, n_episodes=5, max_depth=max_depth)


@pytest.mark.kitti
def test_step_metrics_match_the_reference_on_real_kitti_frames(kitti_root):
    from inpaintenv.data import KittiDepth

    frames = KittiDepth(kitti_root, split="train").load_batch(range(3))
    env = gym.make("inpaintenv/DepthInpaint-v0", dataset=ArrayDataset(frames), unfilled="zero")
    _check_episodes(env, frames, n_episodes=2)


def test_step_scores_with_the_pixels_gathered_at_reset(dataset, monkeypatch):
    """The speed design: one gather per episode at reset, one scoring at step, no full-frame metrics."""
    calls = {"init": 0, "metrics": 0}

    class Counting(ScoredPixels):
        def __init__(self, gt, hole, **kwargs):
            calls["init"] += 1
            super().__init__(gt, hole, **kwargs)

        def metrics(self, pred, **kwargs):
            calls["metrics"] += 1
            return super().metrics(pred, **kwargs)

    def no_frame_metrics(*args, **kwargs):
        raise AssertionError("the env must not call frame_metrics (it regathers the whole frame)")

    monkeypatch.setattr(inpaint_module, "ScoredPixels", Counting)
    monkeypatch.setattr(metrics_module, "frame_metrics", no_frame_metrics)
    if hasattr(inpaint_module, "frame_metrics"):
        monkeypatch.setattr(inpaint_module, "frame_metrics", no_frame_metrics)
    env = DepthInpaintEnv(dataset, unfilled="zero")
    obs, _ = env.reset(seed=0)
    assert calls == {"init": 1, "metrics": 0}
    env.step(obs["depth"])
    assert calls == {"init": 1, "metrics": 1}
    # The caller's action is not copied when nothing will render it.
    assert env._pred is None


def test_observations_are_fresh_arrays(dataset):
    env = DepthInpaintEnv(dataset, unfilled="zero")
    obs, info = env.reset(seed=0)
    want_depth, want_hole = obs["depth"].copy(), obs["hole"].copy()
    obs["depth"][:] = 99.0  # the caller fills in place: the step observation is unaffected
    obs["hole"][:] = 0
    step_obs, *_ = env.step(obs["depth"])
    np.testing.assert_array_equal(step_obs["depth"], want_depth)
    np.testing.assert_array_equal(step_obs["hole"], want_hole)
    # The next episode serves new arrays, not the ones handed out before.
    obs2, _ = env.reset(options={"index": info["index"], "mask_seed": info["mask_seed"]})
    assert not np.shares_memory(obs2["depth"], step_obs["depth"])
    np.testing.assert_array_equal(obs2["depth"], want_depth)


def test_scoring_does_not_depend_on_the_dataset_array_after_reset(frames):
    env = DepthInpaintEnv(ArrayDataset(frames), unfilled="zero")
    obs, info = env.reset(seed=0)
    want = boolean_mask_metrics(obs["depth"], frames[info["index"]].copy(), obs["hole"].astype(bool))
    frames[info["index"]] = 1.0  # the array dataset holds a view of the caller's frames
    _, _, _, _, step_info = env.step(obs["depth"])
    assert_same_metrics(step_info, want)


@pytest.mark.slow
def test_env_within_2x_of_a_plain_numpy_loop():
    """The issue's target as a CPU-time ratio (insensitive to other jobs' load), generously bounded."""
    sys.path.insert(0, str(_BENCHMARKS))
    try:
        import bench_env
    finally:
        sys.path.remove(str(_BENCHMARKS))
    rng = np.random.default_rng(0)
    frames = rng.uniform(2.0, 80.0, (4, 352, 1216)).astype(np.float32)
    frames[rng.random(frames.shape) < 0.8] = 0.0  # KITTI's ground truth covers ~20 %
    env = gym.make("inpaintenv/DepthInpaint-v0", dataset=ArrayDataset(frames), unfilled="zero")
    plain, served = bench_env.plain_loop(frames, 30), bench_env.env_loop(env, 30)
    best = {"plain": np.inf, "env": np.inf}
    for _ in range(3):  # interleaved, so both see the same machine
        for name, run in (("plain", plain), ("env", served)):
            t0 = time.process_time()
            run()
            best[name] = min(best[name], time.process_time() - t0)
    assert best["env"] <= 2.0 * best["plain"], best
    # frames/s of CPU time: ~500-800 on an idle 2-core CI machine, 149 once late in a full suite
    # run (the plain loop slowed alike); the floor catches a several-fold regression, the
    # ratio above is the target
    assert 30 / best["env"] >= 100, best
