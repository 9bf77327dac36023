"""Protocol-specific structure of lidar-dropout-v1, ego-occlusion-v1 and freeform-v1."""

from __future__ import annotations

import numpy as np
import pytest

from inpaintenv.masks import EgoOcclusionV1, FreeformV1, LidarDropoutV1, get_protocol, mask_rng

SHAPE = (88, 304)


def test_lidar_beams_alone_cover_the_beam_budget():
    proto = LidarDropoutV1()
    H, W = SHAPE
    for i in range(100):
        beams = proto._beams(SHAPE, mask_rng(proto.name, 0, i))
        per_column = beams.sum(axis=0)
        # Every column crosses each band once with the same thickness: constant count.
        assert np.all(per_column == per_column[0])
        assert 0.05 <= per_column[0] / H <= 0.20 + 8 / H


def test_lidar_beams_are_thin_bent_row_bands():
    proto = LidarDropoutV1()
    beams = proto._beams((352, 1216), mask_rng(proto.name, 0, 3))
    rows_hit = beams.any(axis=1).mean()
    assert rows_hit < 0.5  # bands, not a block
    first = beams.argmax(axis=0)
    assert np.abs(np.diff(first)).max() <= 1  # continuous curves, at most 1 px per column


def test_lidar_contains_column_sectors_in_some_frames():
    proto = get_protocol("lidar-dropout-v1")
    full_columns = [proto.mask(SHAPE, 0, i).all(axis=0).any() for i in range(40)]
    assert 5 < sum(full_columns) < 35  # sectors appear with probability 0.5


def test_ego_geometry_is_fixed_up_to_jitter():
    masks = get_protocol("ego-occlusion-v1").masks(SHAPE, seed=0, indices=range(50))
    always = masks.all(axis=0).mean()
    ever = masks.any(axis=0).mean()
    assert ever - always < 0.1  # jitter only moves the boundaries a little
    H, W = SHAPE
    assert masks[:, -1, W // 2].all()  # the bonnet always covers the bottom centre
    assert not masks[:, : H // 2, W // 2].any()  # the middle of the view stays free


@pytest.mark.parametrize("part", ["bonnet", "pole", "mirror"])
def test_ego_parts_are_independent(part):
    full = EgoOcclusionV1()
    alone = EgoOcclusionV1(parts=[part])
    for i in range(5):
        a = alone.mask(SHAPE, 0, i)
        assert a.any()
        # A part drawn alone is within the full mask (the pole may stop at the bonnet).
        if part != "pole":
            assert not (a & ~full.mask(SHAPE, 0, i)).any()
    assert alone.describe()["params"]["parts"] == [part]


def test_ego_bad_parts_are_refused():
    with pytest.raises(ValueError, match="parts"):
        EgoOcclusionV1(parts=["wheel"])
    with pytest.raises(ValueError, match="parts"):
        EgoOcclusionV1(parts=[])


def test_freeform_reaches_its_target():
    proto = FreeformV1()
    for i in range(50):
        # The target is the first draw of the frame's stream.
        f = mask_rng(proto.name, 0, i).uniform(*proto.TARGET)
        m = proto.mask(SHAPE, 0, i)
        assert f <= m.mean() <= f + 0.12  # overshoot: at most about one shape


def test_freeform_strokes_are_thin_structures():
    # Many hole pixels lie near the hole's border (strokes), unlike one big rectangle.
    m = get_protocol("freeform-v1").mask((176, 608), 0, 0)
    interior = m[1:-1, 1:-1] & m[:-2, 1:-1] & m[2:, 1:-1] & m[1:-1, :-2] & m[1:-1, 2:]
    assert interior.sum() < 0.97 * m[1:-1, 1:-1].sum()


def test_smallest_reaching_matches_a_linear_scan():
    from inpaintenv.masks.freeform import _smallest_reaching

    rng = np.random.default_rng(0)
    for _ in range(300):
        limit = int(rng.integers(1, 50))
        values = np.sort(rng.random(limit + 1))  # non-decreasing f(0..limit)
        target = rng.random()
        calls = []

        def f(j):
            calls.append(j)
            return values[j]

        expected = next((j for j in range(1, limit + 1) if values[j] >= target), limit)
        got = _smallest_reaching(f, target, limit, guess=int(rng.integers(-3, limit + 5)))
        assert got == expected
        assert all(1 <= j <= limit for j in calls)


def test_describe_records_the_distribution_constants():
    desc = get_protocol("lidar-dropout-v1").describe()
    assert desc["constants"]["BEAM_FRACTION"] == [0.05, 0.2]
    assert get_protocol("freeform-v1").describe()["constants"]["N_MAX"] == 48
