"""DepthInpaintEnv with a single LiDAR scan as the input (densify-v1 and a hole cut into the scan)."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from estimators.classical import NearestInpainter
from inpaintenv.data import SyntheticStreets
from inpaintenv.envs import DepthInpaintEnv
from inpaintenv.evaluate import evaluate
from inpaintenv.exceptions import InvalidInputError

SHAPE = (48, 160)


@pytest.fixture(scope="module")
def scans() -> SyntheticStreets:
    return SyntheticStreets(n=4, seed=2, frame_shape=SHAPE, frames_per_drive=2, input="scan")


@pytest.mark.parametrize("protocol", ["densify-v1", "rect-v1"])
def test_the_observation_is_the_scan_and_says_what_was_measured(scans, protocol):
    env = DepthInpaintEnv(scans, protocol=protocol)
    obs, info = env.reset(options={"index": 1, "mask_seed": 3})
    scan, gt = scans.load_pairs([1])
    hole = obs["hole"].astype(bool)
    np.testing.assert_array_equal(obs["depth"], np.where(hole, 0.0, scan[0]))
    np.testing.assert_array_equal(obs["measured"], (scan[0] > 0) & ~hole)
    assert obs in env.observation_space and info["input_kind"] == "scan"
    # The step's info and reward are evaluate's row for the same (frame, seed).
    pred = NearestInpainter(n_jobs=1).predict(np.where(obs["measured"] > 0, obs["depth"], np.nan))
    _, reward, terminated, _, step_info = env.step(pred)
    row = evaluate(NearestInpainter(n_jobs=1), scans, protocol=protocol, seeds=[3], indices=[1],
                   progress=False).rows[0]
    for key in ("unmeasured_rmse", "unmeasured_count", "kitti_rmse", "kitti_imae", "all_rmse", "hole_count"):
        np.testing.assert_equal(step_info[key], row[key])
    headline = "unmeasured_rmse" if protocol == "densify-v1" else "hole_rmse"
    assert terminated and reward == -step_info[headline] and np.isfinite(reward)


def test_a_map_env_observes_what_it_was_given(scans):
    env = DepthInpaintEnv(SyntheticStreets(n=2, frame_shape=SHAPE))
    obs, info = env.reset(seed=0)
    np.testing.assert_array_equal(obs["measured"], obs["depth"] > 0)
    assert info["input_kind"] == "map"
    with pytest.raises(InvalidInputError, match="input kind is 'map'"):
        DepthInpaintEnv(SyntheticStreets(n=2, frame_shape=SHAPE), input="scan")
    assert DepthInpaintEnv(scans, input="scan").input_kind == "scan"


def test_a_density_variant_env_observes_the_thinned_scan():
    env = gym.make("inpaintenv/SyntheticInpaint-v0", n=2, seed=0, frame_shape=(64, 160), input="scan-rings16-v1",
                   protocol="rect-v1")
    obs, info = env.reset(options={"index": 0, "mask_seed": 1})
    thinned = env.unwrapped.dataset.input_frame(0)
    assert info["input_kind"] == "scan-rings16-v1"
    np.testing.assert_array_equal(obs["measured"].astype(bool), (thinned > 0) & ~obs["hole"].astype(bool))
    full = SyntheticStreets(n=2, seed=0, frame_shape=(64, 160), input="scan").input_frame(0)
    assert 0 < np.count_nonzero(obs["measured"]) < 0.5 * np.count_nonzero(full)


@pytest.mark.parametrize("protocol", ["densify-v1", "rect-v1"])
def test_gymnasium_checker_passes_on_scans(protocol):
    env = gym.make("inpaintenv/SyntheticInpaint-v0", n=3, seed=0, frame_shape=(64, 160), input="scan",
                   protocol=protocol)
    assert env.unwrapped.input_kind == "scan"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped)


@pytest.mark.kitti
def test_kitti_scan_env(kitti_root):
    env = gym.make("inpaintenv/KittiInpaint-v0", root=str(kitti_root), split="val_selection", input="scan",
                   protocol="densify-v1")
    obs, info = env.reset(seed=0)
    assert obs in env.observation_space and 0.02 < obs["measured"].mean() < 0.08
    _, reward, _, _, step_info = env.step(np.full((352, 1216), 10.0, np.float32))
    assert reward == -step_info["unmeasured_rmse"] < 0 and step_info["unmeasured_count"] > 0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped)
