"""A submission to the env may carry a per-pixel interval: info gets coverage and width."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from inpaintenv.envs import DepthInpaintEnv
from inpaintenv.evaluate import evaluate
from inpaintenv.metrics import INTERVAL_COLUMNS


def _episode(env, seed=0):
    obs, _ = env.reset(seed=seed)
    depth = obs["depth"].copy()
    depth[obs["hole"] == 1] = 15.0
    return depth, obs["hole"].astype(bool)


def test_dict_action_adds_the_interval_columns(dataset, frames):
    env = DepthInpaintEnv(dataset)
    depth, _ = _episode(env)
    _, reward, _, _, info = env.step({"depth": depth, "low": np.maximum(depth - 3, 0), "high": depth + 3})
    assert set(INTERVAL_COLUMNS) <= set(info)
    # The reward is the plain action's.
    depth2, _ = _episode(env)
    _, plain_reward, _, _, plain_info = env.step(depth2)
    assert reward == plain_reward and not set(INTERVAL_COLUMNS) & set(plain_info)


def test_env_coverage_equals_a_numpy_recomputation_and_evaluate(dataset, frames):
    env = DepthInpaintEnv(dataset)
    obs, ep = env.reset(options={"index": 1, "mask_seed": 0})
    hole = obs["hole"].astype(bool)
    depth = np.where(hole, 15.0, obs["depth"]).astype(np.float32)
    low, high = np.maximum(depth - 10, 0), depth + 10
    info = env.step({"depth": depth, "low": low, "high": high})[4]
    gt = frames[1]
    inside = [low[y, x] <= gt[y, x] <= high[y, x] for y, x in zip(*np.nonzero(hole & (gt > 0)))]
    assert info["hole_coverage"] == pytest.approx(sum(inside) / len(inside), abs=1e-12)
    assert info["hole_interval_width"] == pytest.approx(20.0, rel=1e-6)

    class Fill15:
        def predict(self, x):
            return np.nan_to_num(x, nan=15.0).astype(np.float32)

        def predict_interval(self, x, coverage=0.9):
            p = self.predict(x)
            return np.maximum(p - 10, 0), p + 10

    row = evaluate(Fill15(), dataset, seeds=[0], indices=[1], intervals=0.9, progress=False).rows[0]
    assert {c: info[c] for c in INTERVAL_COLUMNS} == {c: row[c] for c in INTERVAL_COLUMNS}


def test_std_action_uses_the_env_coverage(dataset):
    env = DepthInpaintEnv(dataset, interval_coverage=0.5)
    depth, _ = _episode(env)
    info = env.step({"depth": depth, "std": np.full_like(depth, 2.0)})[4]
    # z(0.5) = 0.674...: width 2·z·2 where nothing is clipped at 0 (depth 15 m in the hole).
    assert info["hole_interval_width"] == pytest.approx(4 * 0.6744897501960817, rel=1e-6)


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda d: {"depth": d, "low": d + 1, "high": d + 2}, "does not hold the prediction"),
        (lambda d: {"depth": d, "low": d + 1, "high": d - 1}, "inverted"),
        (lambda d: {"depth": d, "low": d * np.nan, "high": d}, "NaN"),
        (lambda d: {"depth": d, "std": -np.ones_like(d)}, "std"),
        (lambda d: {"depth": d, "low": d}, "keys"),
        (lambda d: {"depth": d, "low": d[:-1], "high": d[:-1]}, "shape"),
    ],
)
def test_bad_interval_is_refused_and_the_episode_stays_open(dataset, make, message):
    env = DepthInpaintEnv(dataset)
    depth, _ = _episode(env)
    with pytest.raises(ValueError, match=message):
        env.step(make(depth))
    env.step(depth)  # the episode was not ended by the refused action


def test_bad_env_coverage_is_refused(dataset):
    with pytest.raises(ValueError, match="interval_coverage"):
        DepthInpaintEnv(dataset, interval_coverage=1.0)


def test_checker_still_passes_with_an_interval_coverage(dataset):
    env = gym.make("inpaintenv/DepthInpaint-v0", dataset=dataset, interval_coverage=0.8)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped)
    env.close()


def test_env_info_has_the_uncertainty_figures_evaluate_gives(dataset):
    """AUSE, AURG, AUCE and the coverage at each level: the env's info equals evaluate's row."""

    class Fill15Std:
        def predict(self, x, return_std=False):
            p = np.nan_to_num(x, nan=15.0).astype(np.float32)
            return (p, np.where(np.isnan(x), 0.5 + 0.1 * np.arange(x.shape[-1]), 0.0)) if return_std else p

    env = DepthInpaintEnv(dataset, interval_coverage=0.9)
    obs, _ = env.reset(options={"index": 1, "mask_seed": 0})
    x = np.where(obs["hole"].astype(bool), np.nan, obs["depth"]).astype(np.float32)
    depth, std = Fill15Std().predict(x, return_std=True)
    info = env.step({"depth": depth, "std": std})[4]
    row = evaluate(Fill15Std(), dataset, seeds=[0], indices=[1], intervals=0.9, progress=False).rows[0]
    names = ["ause_rmse", "aurg_rmse", "ause_mae", "aurg_mae", "auce", "coverage_50", "coverage_95",
             "hole_interval_width_median"]
    assert {c: info[c] for c in names} == pytest.approx({c: row[c] for c in names}, rel=1e-9)
    assert info["auce"] > 0 and info["ause_rmse"] >= 0
