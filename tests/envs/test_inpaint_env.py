"""DepthInpaintEnv: checker, spaces, determinism, scoring, bad actions, vector envs, render."""

from __future__ import annotations

import math
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import inpaintenv  # noqa: F401  (registers the env ids)
from inpaintenv.data import ArrayDataset
from inpaintenv.envs import DEPTH_LIMIT, DepthInpaintEnv, draw_scored_hole
from inpaintenv.masks import get_protocol
from inpaintenv.metrics import frame_metrics

SHAPE = (24, 40)  # as in conftest.py


def _make(dataset, **kw):
    return gym.make("inpaintenv/DepthInpaint-v0", dataset=dataset, **kw)


@pytest.mark.parametrize("render_mode", [None, "rgb_array"])
def test_check_env_without_warnings(dataset, render_mode):
    env = _make(dataset, render_mode=render_mode)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped)
    env.close()


def test_registered_ids():
    for env_id in ("inpaintenv/KittiInpaint-v0", "inpaintenv/SyntheticInpaint-v0", "inpaintenv/DepthInpaint-v0"):
        assert env_id in gym.registry


def test_spaces(dataset):
    env = DepthInpaintEnv(dataset)
    depth, hole = env.observation_space["depth"], env.observation_space["hole"]
    assert depth.shape == hole.shape == env.action_space.shape == SHAPE
    assert depth.dtype == np.float32 and hole.dtype == np.uint8 and env.action_space.dtype == np.float32
    for box in (depth, hole, env.action_space):
        assert np.isfinite(box.low).all() and np.isfinite(box.high).all()
    assert env.action_space.high.max() == np.float32(DEPTH_LIMIT)
    obs, info = env.reset(seed=0)
    assert obs in env.observation_space
    assert obs["depth"].dtype == np.float32 and obs["hole"].dtype == np.uint8
    hole_b = obs["hole"].astype(bool)
    assert (obs["depth"][hole_b] == 0).all()
    gt = dataset[info["index"]]
    np.testing.assert_array_equal(obs["depth"][~hole_b], gt[~hole_b])


def test_reset_determinism(dataset):
    env = DepthInpaintEnv(dataset)
    o1, i1 = env.reset(seed=7)
    o2, i2 = env.reset(seed=7)
    assert i1 == i2
    np.testing.assert_array_equal(o1["hole"], o2["hole"])
    np.testing.assert_array_equal(o1["depth"], o2["depth"])
    # Unseeded resets continue the stream: over several episodes frames and masks vary.
    infos = [env.reset()[1] for _ in range(6)]
    assert len({(i["index"], i["mask_seed"]) for i in infos}) > 1


def test_reset_options_index_and_mask_seed_match_protocol(dataset):
    env = DepthInpaintEnv(dataset)
    obs, info = env.reset(seed=123, options={"index": 3})
    assert info["index"] == 3 and info["frame_id"] == dataset.frame_ids[3]
    obs2, info2 = env.reset(seed=123, options={"index": 3})
    assert info2 == info
    np.testing.assert_array_equal(obs["hole"], obs2["hole"])
    # With mask_seed the mask is the one evaluate() uses for (seed, index).
    obs, info = env.reset(options={"index": 2, "mask_seed": 5})
    expected = get_protocol("rect-v1").mask(SHAPE, 5, 2)
    assert info["mask_redraws"] == 0 and info["mask_seed"] == 5
    np.testing.assert_array_equal(obs["hole"].astype(bool), expected)


@pytest.mark.parametrize(
    "options, exc",
    [
        ({"index": 5}, ValueError),
        ({"index": -1}, ValueError),
        ({"index": 1.5}, TypeError),
        ({"mask_seed": -3}, ValueError),
        ({"frame": 0}, ValueError),
    ],
)
def test_bad_reset_options(dataset, options, exc):
    env = DepthInpaintEnv(dataset)
    with pytest.raises(exc, match="option"):
        env.reset(options=options)


def test_step_reward_is_minus_hole_rmse(dataset):
    env = DepthInpaintEnv(dataset)
    obs, info = env.reset(seed=3)
    gt = dataset[info["index"]].astype(np.float64)
    hole = obs["hole"].astype(bool)
    action = np.where(hole, 12.5, obs["depth"]).astype(np.float32)
    _, reward, terminated, truncated, step_info = env.step(action)
    sel = hole & (gt > 0)
    expected = math.sqrt(float(((12.5 - gt[sel]) ** 2).mean()))
    assert reward == pytest.approx(-expected, rel=1e-9)
    assert terminated is True and truncated is False
    assert step_info["hole_rmse"] == pytest.approx(expected)
    assert step_info["hole_count"] == int(sel.sum())
    assert step_info["all_count"] == int((gt > 0).sum())
    for key in ("hole_mae", "hole_irmse", "hole_imae", "hole_psnr", "all_rmse", "all_psnr", "frame_id", "index"):
        assert key in step_info
    assert step_info["index"] == info["index"]


def test_perfect_reconstruction_scores_zero(dataset):
    env = DepthInpaintEnv(dataset)
    _, info = env.reset(seed=0)
    _, reward, *_ = env.step(dataset[info["index"]])
    assert reward == 0.0


def test_step_outside_episode_raises(dataset):
    env = DepthInpaintEnv(dataset)
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.zeros(SHAPE, np.float32))
    env.reset(seed=0)
    env.step(np.ones(SHAPE, np.float32))
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.ones(SHAPE, np.float32))


def test_unfilled_action_is_refused_unless_the_env_says_how_to_score_it(dataset):
    # 0 m left in the hole was scored as 0 m; NaN was refused.
    env = DepthInpaintEnv(dataset)
    env.reset(seed=0, options={"index": 1, "mask_seed": 3})
    gt = dataset[1]
    hole = env._hole
    action = np.where(hole, 0.0, gt).astype(np.float32)
    n = int((hole & (gt > 0)).sum())
    with pytest.raises(ValueError, match=rf"^prediction is 0 m \(unfilled\) at {n} hole pixels with ground truth"):
        env.step(action)
    _, reward, *_ = env.step(np.where(hole, 7.0, gt).astype(np.float32))  # the episode stayed open
    assert np.isfinite(reward)
    for policy in ("zero", "interpolate"):
        env = DepthInpaintEnv(dataset, unfilled=policy)
        env.reset(seed=0, options={"index": 1, "mask_seed": 3})
        _, reward, *_ = env.step(action)
        want = frame_metrics(action, gt, hole, unfilled=policy)["hole_rmse"]
        assert reward == pytest.approx(-float(want))
    with pytest.raises(ValueError, match="unfilled must be one of"):
        DepthInpaintEnv(dataset, unfilled="ignore")
    assert gym.make("inpaintenv/SyntheticInpaint-v0", n=2, frame_shape=(32, 48), unfilled="zero").unwrapped.unfilled == "zero"


def _one_pixel(value, dtype=np.float32):
    action = np.full(SHAPE, 5.0, dtype)
    action[SHAPE[0] // 2, SHAPE[1] // 3] = value
    return action


@pytest.mark.parametrize(
    "action, exc, match",
    [
        (np.zeros((SHAPE[0], SHAPE[1] + 1), np.float32), ValueError, "shape"),
        (np.zeros((1, *SHAPE), np.float32), ValueError, "shape"),
        (np.full(SHAPE, np.nan, np.float32), ValueError, "NaN"),
        (np.full(SHAPE, np.inf, np.float32), ValueError, "NaN or inf"),
        (np.full(SHAPE, -1.0, np.float32), ValueError, "negative"),
        (np.full(SHAPE, 1e4, np.float32), ValueError, "bound"),
        # One bad pixel in an otherwise valid reconstruction (the quick min/max check).
        (_one_pixel(np.nan), ValueError, "NaN"),
        (_one_pixel(-np.inf), ValueError, "NaN or inf"),
        (_one_pixel(-0.5), ValueError, "negative"),
        (_one_pixel(DEPTH_LIMIT + 1.0), ValueError, "bound"),
        (_one_pixel(1e300, np.float64), ValueError, "bound"),  # inf once stored as float32
        (np.ones(SHAPE, np.int32), TypeError, "dtype"),
        (np.ones(SHAPE, np.uint8), TypeError, "action has integer dtype uint8"),
        (np.ones(SHAPE, bool), TypeError, "dtype"),
        # Once scored on the data under the mask; refused as everywhere else.
        (np.ma.masked_array(np.full(SHAPE, 5.0, np.float32), mask=np.eye(*SHAPE, dtype=bool)), TypeError,
         "action is a numpy masked array"),
        ("deep", TypeError, "dtype"),
    ],
)
def test_bad_actions_raise_and_keep_episode(dataset, action, exc, match):
    env = DepthInpaintEnv(dataset)
    env.reset(seed=0)
    with pytest.raises(exc, match=match):
        env.step(action)
    # The episode is still open: a valid action is scored afterwards.
    _, reward, terminated, _, _ = env.step(np.ones(SHAPE, np.float32))
    assert terminated and reward < 0


def test_float64_action_accepted_and_not_kept(dataset):
    env = DepthInpaintEnv(dataset, render_mode="rgb_array")
    env.reset(seed=0)
    action = np.ones(SHAPE, np.float64)
    env.step(action)
    action[:] = 50.0  # modifying the caller's array afterwards changes nothing
    assert env.unwrapped._pred.max() == 1.0


def test_hole_without_ground_truth_is_redrawn(frame_factory):
    frames = frame_factory(2)
    frames[0] = 0.0
    frames[0, :, :2] = 10.0  # only two columns of ground truth
    env = DepthInpaintEnv(ArrayDataset(frames))
    proto = get_protocol("rect-v1")
    # Find a seed whose first mask misses the measured columns, so a redraw is needed.
    seed = next(s for s in range(200) if not proto.mask(SHAPE, s, 0)[:, :2].any())
    obs, info = env.reset(options={"index": 0, "mask_seed": seed})
    assert info["mask_redraws"] >= 1
    assert (obs["hole"].astype(bool) & (frames[0] > 0)).any()
    hole2, redraws2 = draw_scored_hole(proto, frames[0], seed, 0)
    assert redraws2 == info["mask_redraws"]
    np.testing.assert_array_equal(hole2, obs["hole"].astype(bool))


def test_frame_without_ground_truth(frame_factory):
    frames = frame_factory(3)
    frames[1] = 0.0
    env = DepthInpaintEnv(ArrayDataset(frames))
    with pytest.raises(ValueError, match="no valid ground truth"):
        env.reset(options={"index": 1})
    # Random draws never serve the empty frame.
    assert all(env.reset(seed=s)[1]["index"] != 1 for s in range(20))
    empty = DepthInpaintEnv(ArrayDataset(np.zeros((2, *SHAPE), np.float32)))
    with pytest.raises(RuntimeError, match="no valid ground truth"):
        empty.reset(seed=0)


def test_bad_constructor_arguments(frames):
    with pytest.raises(ValueError, match="render_mode"):
        DepthInpaintEnv(frames, render_mode="human")
    with pytest.raises(ValueError, match="max_depth"):
        DepthInpaintEnv(frames, max_depth=0)
    with pytest.raises(KeyError, match="protocol"):
        DepthInpaintEnv(frames, protocol="nope")
    too_deep = frames.copy()
    too_deep[0, 0, 0] = 300.0
    # Arrays are checked when wrapped: depth beyond the 16-bit range is refused up front.
    with pytest.raises(ValueError, match="above 255.996 m"):
        DepthInpaintEnv(too_deep)
    # (H, W, 1) used to become H one-pixel-wide frames.
    with pytest.raises(ValueError, match="trailing size-1 axis looks like a channel axis"):
        DepthInpaintEnv(frames[0][..., None])


@pytest.mark.parametrize("max_depth, error", [(math.nan, ValueError), (math.inf, ValueError), ("80", TypeError),
                                              (-1.0, ValueError)])
def test_max_depth_must_be_finite_and_positive(frames, max_depth, error):
    with pytest.raises(error, match="max_depth must be a finite positive number of metres"):
        DepthInpaintEnv(frames, max_depth=max_depth)
    with pytest.raises(ValueError, match="max_depth must be in"):
        DepthInpaintEnv(frames, max_depth=300.0)


def test_custom_dataset_frame_above_the_bound_is_named_on_reset(frames):
    from inpaintenv.data import DepthDataset

    class Raw(DepthDataset):
        frame_shape = SHAPE
        groups = np.asarray(["d"])
        frame_ids = ("d/0",)

        def _load(self, index):
            return np.full(SHAPE, 300.0, np.float32)

    with pytest.raises(ValueError, match="frame 0 has depth up to 300 m, above 255.996 m"):
        DepthInpaintEnv(Raw()).reset(options={"index": 0})


def test_negative_reset_seed_is_gymnasium_s_error(dataset):
    # Left to Gymnasium: its own clear error is part of the Env.reset contract.
    with pytest.raises(gym.error.Error, match="Seed must be"):
        DepthInpaintEnv(dataset).reset(seed=-1)


@pytest.mark.parametrize("vector_cls", [gym.vector.SyncVectorEnv, gym.vector.AsyncVectorEnv])
def test_vector_envs_same_step_autoreset(dataset, vector_cls):
    fns = [lambda: DepthInpaintEnv(dataset) for _ in range(2)]
    envs = vector_cls(fns, autoreset_mode=gym.vector.AutoresetMode.SAME_STEP)
    try:
        obs, info = envs.reset(seed=[0, 1])
        assert obs["depth"].shape == (2, *SHAPE) and obs["hole"].dtype == np.uint8
        first_index = info["index"].copy()
        gts = np.stack([dataset[int(i)] for i in first_index])
        for _ in range(3):
            obs_before = obs
            obs, reward, terminated, truncated, info = envs.step(gts)
            assert terminated.all() and not truncated.any()
            np.testing.assert_array_equal(reward, 0.0)  # perfect reconstructions
            # Same-step autoreset: final obs and info of the finished episode come back ...
            assert "final_obs" in info and "final_info" in info
            np.testing.assert_array_equal(info["final_obs"][0]["hole"], obs_before["hole"][0])
            np.testing.assert_array_equal(info["final_info"]["hole_rmse"], 0.0)
            # ... with the next episode's observation already served.
            assert obs in envs.observation_space
            gts = np.stack([dataset[int(i)] for i in info["index"]])
    finally:
        envs.close()


def test_vector_env_from_registered_id(dataset):
    envs = gym.make_vec(
        "inpaintenv/DepthInpaint-v0", num_envs=2, vectorization_mode="sync",
        vector_kwargs={"autoreset_mode": gym.vector.AutoresetMode.SAME_STEP}, dataset=dataset,
    )
    envs.reset(seed=0)
    _, reward, terminated, _, _ = envs.step(np.ones((2, *SHAPE), np.float32))
    assert terminated.all() and (reward < 0).all()
    envs.close()


def test_render_panel_shape_and_dtype(dataset):
    env = DepthInpaintEnv(dataset, render_mode="rgb_array")
    env.reset(seed=0)
    before = env.render()
    assert before.dtype == np.uint8 and before.ndim == 3 and before.shape[2] == 3
    assert before.shape[1] == SHAPE[1]
    assert before.shape[0] == 4 * (SHAPE[0] + 18) + 2 * 30  # four tiles, two colour bars
    env.step(np.ones(SHAPE, np.float32))
    after = env.render()
    assert after.dtype == np.uint8 and after.shape[1] == SHAPE[1]
    assert after.shape[0] > before.shape[0]  # a title line with the metrics
    assert DepthInpaintEnv(dataset).render() is None


def test_synthetic_env():
    env = gym.make("inpaintenv/SyntheticInpaint-v0", n=3, seed=0, frame_shape=(64, 160))
    obs, info = env.reset(seed=0)
    assert obs["depth"].shape == (64, 160) and info["frame_id"].startswith("synthetic")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped)


@pytest.mark.kitti
def test_kitti_env(kitti_root):
    env = gym.make("inpaintenv/KittiInpaint-v0", root=str(kitti_root), split="val")
    obs, info = env.reset(seed=0)
    assert obs["depth"].shape == (352, 1216) and info["frame_id"].startswith("2011_10_03_drive_9101")
    assert obs in env.observation_space
    _, reward, terminated, _, step_info = env.step(np.full((352, 1216), 10.0, np.float32))
    assert terminated and reward == -step_info["hole_rmse"] and reward < 0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped)



@pytest.mark.kitti
def test_kitti_train_random_episodes_are_scorable(kitti_root):
    env = gym.make("inpaintenv/KittiInpaint-v0", root=str(kitti_root), split="train")
    for seed in range(3):
        obs, info = env.reset(seed=seed)
        assert info["frame_id"].startswith("2011_09_26_drive_900")
        assert (obs["hole"].astype(bool) & (env.unwrapped.dataset[info["index"]] > 0)).any()
