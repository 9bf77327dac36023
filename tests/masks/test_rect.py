"""rect-v1: the study's protocol, checked rectangle by rectangle."""

from __future__ import annotations

import math

import numpy as np
import pytest

from inpaintenv.masks import RectV1, get_protocol, mask_rng

SHAPE = (88, 304)
N = 600


@pytest.fixture(scope="module")
def draws():
    proto = RectV1()
    return [proto.rectangles(SHAPE, mask_rng(proto.name, 0, i)) for i in range(N)]


def test_rectangles_reproduce_the_mask():
    proto = get_protocol("rect-v1")
    for i in range(20):
        mask = proto.mask(SHAPE, seed=2, index=i)
        rebuilt = np.zeros(SHAPE, bool)
        for top, left, h, w in proto.rectangles(SHAPE, mask_rng("rect-v1", 2, i)):
            rebuilt[top : top + h, left : left + w] = True
        np.testing.assert_array_equal(mask, rebuilt)


def test_each_rectangle_covers_5_to_20_percent_and_lies_inside(draws):
    H, W = SHAPE
    for rects in draws:
        for top, left, h, w in rects:
            assert 0.05 <= h * w / (H * W) <= 0.20
            assert 0 <= top and top + h <= H and 0 <= left and left + w <= W


def test_one_to_three_rectangles_equally_often(draws):
    counts = np.bincount([len(r) for r in draws], minlength=4)
    assert counts[0] == 0 and counts[1:].sum() == N
    # Uniform on {1, 2, 3}: each ~200 of 600; 5 sigma of a binomial is ~58.
    assert np.all(np.abs(counts[1:] - N / 3) < 60), counts


def test_aspect_ratio_within_documented_range(draws):
    # s = (w/W)/(h/H) is log-uniform on [1/2, 2]; rounding to pixels moves it a little.
    H, W = SHAPE
    rel = np.array([(w / W) / (h / H) for rects in draws for _, _, h, w in rects])
    tol = 1.1  # one pixel of 13+ rows at this size
    assert rel.min() >= 0.5 / tol and rel.max() <= 2.0 * tol
    # Both ends are reached (the distribution really spans the range).
    assert rel.min() < 0.6 and rel.max() > 1.7
    # Log-uniform: the median of log s is near 0.
    assert abs(np.median(np.log(rel))) < 0.1


def test_area_fraction_is_spread_over_the_range(draws):
    H, W = SHAPE
    a = np.array([h * w / (H * W) for rects in draws for _, _, h, w in rects])
    assert a.min() < 0.06 and a.max() > 0.19
    assert abs(a.mean() - 0.125) < 0.01  # mean of U(0.05, 0.20)


@pytest.mark.parametrize("shape", [(16, 16), (1, 40), (40, 1), (1, 20), (3, 3), (5, 200), (200, 5)])
def test_small_images_stay_in_bounds(shape):
    H, W = shape
    proto = RectV1()
    for i in range(200):
        rects = proto.rectangles(shape, mask_rng(proto.name, 0, i))
        assert 1 <= len(rects) <= 3
        for top, left, h, w in rects:
            assert h >= 1 and w >= 1
            assert 0 <= top and top + h <= H and 0 <= left and left + w <= W
            assert 0.05 - 1e-12 <= h * w / (H * W) <= 0.20 + 1e-12


@pytest.mark.parametrize("shape", [(1, 1), (2, 2), (1, 4), (4, 1)])
def test_impossible_sizes_raise_a_clear_error(shape):
    with pytest.raises(ValueError, match="too small"):
        get_protocol("rect-v1").mask(shape, seed=0, index=0)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"min_rects": 0},
        {"min_rects": 3, "max_rects": 2},
        {"min_area": 0.0},
        {"min_area": 0.3, "max_area": 0.2},
        {"max_area": 1.5},
        {"max_relative_aspect": 0.5},
    ],
)
def test_bad_parameters_are_refused(kwargs):
    with pytest.raises(ValueError):
        RectV1(**kwargs)


def test_non_integer_counts_are_refused():
    with pytest.raises(TypeError):
        RectV1(max_rects=2.5)


@pytest.mark.parametrize("value", [math.inf, math.nan])
def test_infinite_aspect_is_refused(value):
    # inf passed ">= 1" and overflowed in numpy when drawing.
    with pytest.raises(ValueError, match="max_relative_aspect must be a finite number >= 1"):
        RectV1(max_relative_aspect=value)


def test_non_numeric_areas_are_refused():
    with pytest.raises(TypeError, match="min_area must be a number, got '0.1'"):
        RectV1(min_area="0.1")


def test_describe_records_parameters():
    desc = RectV1(max_rects=2).describe()
    assert desc["params"]["max_rects"] == 2
    assert desc["hole_fraction_range"] == [0.05, 0.4]
    assert math.isclose(desc["params"]["min_area"], 0.05)
