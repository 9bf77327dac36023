"""SyntheticStreets: determinism, density per kind, consistency between kinds, options."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from inpaintenv.conventions import check_depth
from inpaintenv.data import SyntheticStreets
from inpaintenv.data.synthetic import _cached_scene

SMALL = (64, 160)


@pytest.fixture(scope="module")
def full_frames() -> dict[str, np.ndarray]:
    """Frames 0, 5 and 11 of each kind at KITTI's crop size (shared: rendering costs ~50 ms)."""
    return {kind: SyntheticStreets(n=12, seed=3, kind=kind)[[0, 5, 11]].load_batch(range(3))
            for kind in ("dense", "groundtruth", "velodyne_raw")}


def test_deterministic_and_order_independent():
    a = SyntheticStreets(n=20, seed=7, frame_shape=SMALL)
    forward = [a[i] for i in (3, 9, 17)]
    _cached_scene.cache_clear()
    b = SyntheticStreets(n=20, seed=7, frame_shape=SMALL)
    backward = [b[i] for i in (17, 9, 3)][::-1]
    for x, y in zip(forward, backward):
        np.testing.assert_array_equal(x, y)
    np.testing.assert_array_equal(a[[9]][0], forward[1])  # through a Subset
    assert not np.array_equal(SyntheticStreets(n=20, seed=8, frame_shape=SMALL)[3], forward[0])


def test_same_frames_in_another_process():
    code = (
        "from inpaintenv.data import SyntheticStreets; import hashlib; "
        f"print(hashlib.sha1(SyntheticStreets(n=20, seed=7, frame_shape={SMALL})[9].tobytes()).hexdigest())"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    import hashlib

    here = SyntheticStreets(n=20, seed=7, frame_shape=SMALL)[9]
    assert out.stdout.strip() == hashlib.sha1(here.tobytes()).hexdigest()


def test_density_per_kind(full_frames):
    dens = {k: (v > 0).mean(axis=(1, 2)) for k, v in full_frames.items()}
    # Measured on the real slice (docs/data.md): groundtruth 15-34 %, velodyne_raw 3.5-4.5 %.
    assert (dens["dense"] > 0.6).all()
    assert ((0.12 < dens["groundtruth"]) & (dens["groundtruth"] < 0.35)).all()
    assert ((0.02 < dens["velodyne_raw"]) & (dens["velodyne_raw"] < 0.07)).all()


def test_coverage_nests_and_values_equal_dense(full_frames):
    dense, gt, raw = full_frames["dense"], full_frames["groundtruth"], full_frames["velodyne_raw"]
    assert ((gt > 0) <= (dense > 0)).all() and ((raw > 0) <= (dense > 0)).all()
    assert ((dense > 0).sum((1, 2)) >= (gt > 0).sum((1, 2))).all()
    assert ((gt > 0).sum((1, 2)) >= (raw > 0).sum((1, 2))).all()
    np.testing.assert_array_equal(gt[gt > 0], dense[gt > 0])
    np.testing.assert_array_equal(raw[raw > 0], dense[raw > 0])


def test_kitti_like_structure(full_frames):
    gt = full_frames["groundtruth"]
    assert not gt[:, :40].any()  # above the LiDAR's top beam: no data, as in KITTI
    assert (gt[:, -100:] > 0).mean() > 0.2  # the road below is well covered
    for depth in full_frames.values():
        check_depth(depth)
        assert depth.dtype == np.float32 and depth.max() <= 80.0
        np.testing.assert_array_equal(depth * 256, np.rint(depth * 256))  # KITTI's 1/256 m


def test_frame_shape_and_groups():
    ds = SyntheticStreets(n=10, seed=0, frame_shape=SMALL, frames_per_drive=4, kind="velodyne_raw")
    assert ds.shape == (10, *SMALL) and ds[9].shape == SMALL
    assert list(ds.groups[:5]) == [ds.groups[0]] * 4 + [ds.groups[4]]
    assert len(np.unique(ds.groups)) == 3
    assert ds.frame_ids[5].endswith("/image_02/0000000001")
    s = ds.summary(n_sample=2)
    assert s["frames"] == 10 and s["drives"] == 3 and s["sampled_frames"] == 2
    assert sorted(s["frames_per_drive"].values()) == [2, 4, 4]


def test_ego_moves_forward_within_a_drive():
    ds = SyntheticStreets(n=2, seed=0, kind="dense", frames_per_drive=2)
    a, b = ds[0], ds[1]
    road = slice(-40, None)  # bottom rows see the road: flat ground keeps its depth
    np.testing.assert_allclose(np.median(a[road]), np.median(b[road]), atol=0.1)
    assert not np.array_equal(a, b)


@pytest.mark.parametrize("kwargs, match", [({"n": 0}, "n must"), ({"kind": "lidar"}, "kind"),
                                           ({"frame_shape": (4, 4)}, "frame_shape"),
                                           ({"frames_per_drive": 0}, "frames_per_drive")])
def test_bad_arguments(kwargs, match):
    with pytest.raises(ValueError, match=match):
        SyntheticStreets(**kwargs)


@pytest.mark.parametrize("kwargs, error, match", [
    ({"n": "abc"}, TypeError, r"^n must be an integer, got 'abc' \(str\)$"),
    ({"n": 2.5}, TypeError, "n must be an integer"),
    ({"n": 10**9}, ValueError, r"^n must be in 1\.\.1000000, got 1000000000$"),
    ({"frames_per_drive": "x"}, TypeError, "frames_per_drive must be an integer, got 'x'"),
    ({"frame_shape": ("abc", 5)}, TypeError, r"frame_shape must be two integers \(H, W\), got \('abc', 5\)"),
    ({"frame_shape": "352x1216"}, TypeError, "frame_shape must be two integers"),
    ({"frame_shape": (60000, 60000)}, ValueError,
     r"frame_shape 60000 x 60000 is 3,600,000,000 pixels, more than the 50,000,000 a frame may have \(MAX_FRAME_PIXELS\)"),
])
def test_counts_and_sizes_are_checked_with_one_line_naming_the_parameter(kwargs, error, match):
    # int("abc") said "invalid literal for int() with base 10: 'abc'"; 60000 x 60000 allocated without bound.
    with pytest.raises(error, match=match):
        SyntheticStreets(**kwargs)


@pytest.mark.parametrize("seed, error", [(0.9, TypeError), (True, TypeError), ("1", TypeError), (-1, ValueError)])
def test_seed_is_not_truncated(seed, error):
    # SyntheticStreets(seed=0.9) used to serve seed 0's frames.
    with pytest.raises(error, match="seed must be a non-negative integer"):
        SyntheticStreets(n=2, seed=seed, frame_shape=(16, 24))


def test_frames_stay_within_the_16_bit_depth_range():
    from inpaintenv.conventions import DEPTH_LIMIT

    ds = SyntheticStreets(n=2, seed=0, frame_shape=(64, 160), kind="dense")
    assert 0 < ds.load_batch(range(2)).max() < DEPTH_LIMIT
