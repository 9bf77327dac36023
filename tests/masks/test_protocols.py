"""Properties every registered occlusion protocol must have."""

from __future__ import annotations

import json

import numpy as np
import pytest

from inpaintenv.masks import (
    OcclusionProtocol,
    available_protocols,
    get_protocol,
    mask_rng,
    register_protocol,
)

SHAPE = (88, 304)  # a quarter of the 352×1216 KITTI crop: same geometry, 16x fewer pixels
N_STATS = 200
NEW = ["lidar-dropout-v1", "ego-occlusion-v1", "freeform-v1", "mixed-v1"]
ALL = ["rect-v1", *NEW]


def test_registry_lists_all_protocols():
    assert set(ALL) <= set(available_protocols())
    assert available_protocols() == sorted(available_protocols())


def test_unknown_name_lists_known_names():
    with pytest.raises(KeyError) as err:
        get_protocol("rect-v9")
    for name in ALL:
        assert name in str(err.value)


def test_instances_pass_through_and_duplicates_are_refused():
    proto = get_protocol("freeform-v1")
    assert get_protocol(proto) is proto

    class Clash(OcclusionProtocol):
        name = "rect-v1"

        def sample(self, shape, rng):
            return np.zeros(shape, bool)

    with pytest.raises(ValueError, match="already registered"):
        register_protocol(Clash)


@pytest.mark.parametrize("name", ALL)
class TestEveryProtocol:
    def test_dtype_and_shape(self, name):
        m = get_protocol(name).mask(SHAPE, seed=0, index=0)
        assert m.dtype == np.bool_ and m.shape == SHAPE

    def test_name_description_and_describe(self, name):
        proto = get_protocol(name)
        assert proto.name == name and proto.description
        desc = proto.describe()
        json.dumps(desc)  # must be serialisable for results.json
        assert desc["name"] == name
        lo, hi = desc["hole_fraction_range"]
        assert 0 <= lo < hi <= 1

    def test_deterministic_from_seed_and_index(self, name):
        a = get_protocol(name).mask(SHAPE, seed=3, index=11)
        b = get_protocol(name).mask(SHAPE, seed=3, index=11)  # fresh instance
        np.testing.assert_array_equal(a, b)
        np.testing.assert_array_equal(a, get_protocol(name).sample(SHAPE, mask_rng(name, 3, 11)))

    def test_order_independent(self, name):
        proto = get_protocol(name)
        forward = proto.masks(SHAPE, seed=1, indices=[0, 1, 2, 3])
        backward = proto.masks(SHAPE, seed=1, indices=[3, 2, 1, 0])[::-1]
        np.testing.assert_array_equal(forward, backward)
        np.testing.assert_array_equal(forward[2], proto.mask(SHAPE, seed=1, index=2))

    def test_seeds_and_indices_differ(self, name):
        proto = get_protocol(name)
        base = proto.mask(SHAPE, seed=0, index=0)
        assert not np.array_equal(base, proto.mask(SHAPE, seed=1, index=0))
        assert not np.array_equal(base, proto.mask(SHAPE, seed=0, index=1))

    def test_hole_fraction_within_documented_range(self, name):
        proto = get_protocol(name)
        lo, hi = proto.hole_fraction_range()
        frac = proto.masks(SHAPE, seed=0, indices=range(N_STATS)).mean(axis=(1, 2))
        assert frac.min() >= lo and frac.max() <= hi, (frac.min(), frac.max())
        # Not degenerate: masks vary from frame to frame.
        assert frac.std() > 0.005

    def test_kitti_size(self, name):
        m = get_protocol(name).mask((352, 1216), seed=0, index=5)
        lo, hi = get_protocol(name).hole_fraction_range()
        assert m.shape == (352, 1216) and lo <= m.mean() <= hi

    @pytest.mark.parametrize("bad", [(0, 10), (10, 0), (5,), (-1, 8)])
    def test_bad_shape_is_a_clear_error(self, name, bad):
        with pytest.raises(ValueError, match="shape"):
            get_protocol(name).mask(bad, seed=0, index=0)

    def test_negative_seed_or_index_is_a_clear_error(self, name):
        with pytest.raises(ValueError, match="non-negative"):
            get_protocol(name).mask(SHAPE, seed=-1, index=0)
        with pytest.raises(ValueError, match="non-negative"):
            get_protocol(name).mask(SHAPE, seed=0, index=-2)

    @pytest.mark.parametrize("seed", [True, None, 0.5, "0"])
    def test_non_integer_seed_is_a_clear_error(self, name, seed):
        # True used to act as seed 1; None failed with "'<' not supported".
        with pytest.raises(TypeError, match="seed must be a non-negative integer, got"):
            get_protocol(name).mask(SHAPE, seed=seed, index=0)

    def test_non_integer_indices_are_refused_not_truncated(self, name):
        with pytest.raises(TypeError, match=r"indices must be non-negative integers, got \[0.5, 1.5\]"):
            get_protocol(name).masks(SHAPE, 0, [0.5, 1.5])
        with pytest.raises(TypeError, match="index must be a non-negative integer, got 2.0"):
            get_protocol(name).mask(SHAPE, seed=0, index=2.0)
        assert get_protocol(name).masks(SHAPE, np.int64(0), np.array([1, 1])).shape == (2, *SHAPE)


@pytest.mark.parametrize("name", NEW)
@pytest.mark.parametrize("shape", [(16, 16), (1, 300), (300, 1), (8, 8)])
def test_too_small_frames_raise_naming_the_size(name, shape):
    proto = get_protocol(name)
    if shape[0] >= proto.MIN_SHAPE[0] and shape[1] >= proto.MIN_SHAPE[1]:
        assert proto.mask(shape, 0, 0).shape == shape
    else:
        with pytest.raises(ValueError, match=f"{shape[0]}x{shape[1]}"):
            proto.mask(shape, 0, 0)


@pytest.mark.parametrize("name", NEW)
def test_smallest_allowed_frame_works(name):
    proto = get_protocol(name)
    for i in range(20):
        m = proto.mask(proto.MIN_SHAPE, seed=0, index=i)
        assert m.shape == proto.MIN_SHAPE and m.any()


@pytest.mark.parametrize("name", ALL)
@pytest.mark.parametrize("bad", [(88.5, 304), ("88", 304), 88, None])
def test_non_integer_shapes_are_a_clear_error(name, bad):
    with pytest.raises(ValueError, match="shape"):
        get_protocol(name).mask(bad, seed=0, index=0)


@pytest.mark.parametrize("name", ALL)
def test_sample_refuses_anything_but_a_generator(name):
    with pytest.raises(TypeError, match="Generator"):
        get_protocol(name).sample(SHAPE, 0)
    with pytest.raises(TypeError, match="Generator"):
        get_protocol(name).sample(SHAPE, np.random.RandomState(0))


def test_numpy_integer_shapes_are_accepted():
    m = get_protocol("rect-v1").mask((np.int64(88), np.int32(304)), seed=0, index=0)
    assert m.shape == SHAPE


# -- mixed-v1 ----------------------------------------------------------------------------
def test_mixed_draws_every_component_and_matches_it():
    from inpaintenv.masks import MixedV1

    mixed = MixedV1()
    picks = [int(mask_rng("mixed-v1", 0, i).integers(4)) for i in range(40)]
    assert set(picks) == {0, 1, 2, 3}
    for i, k in enumerate(picks[:8]):
        rng = mask_rng("mixed-v1", 0, i)
        rng.integers(4)  # the component draw comes first, from the same stream
        expected = get_protocol(mixed.components[k]).sample(SHAPE, rng)
        np.testing.assert_array_equal(mixed.mask(SHAPE, seed=0, index=i), expected)


def test_mixed_subset_and_bad_components():
    from inpaintenv.masks import MixedV1

    only_rect = MixedV1(components=("rect-v1",))
    assert only_rect.hole_fraction_range() == get_protocol("rect-v1").hole_fraction_range()
    assert only_rect.MIN_SHAPE == get_protocol("rect-v1").MIN_SHAPE
    assert MixedV1().MIN_SHAPE == (32, 32)
    with pytest.raises(ValueError, match="unknown components"):
        MixedV1(components=("rect-v9",))
    with pytest.raises(ValueError, match="components"):
        MixedV1(components="rect-v1")
    with pytest.raises(ValueError, match="at least 32x32"):
        MixedV1().mask((16, 64), seed=0, index=0)
