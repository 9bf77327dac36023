"""The private rasterisers against brute-force references on small grids."""

from __future__ import annotations

import numpy as np
import pytest

from inpaintenv.masks._raster import capsule_intervals, disc_intervals, fill_intervals, smooth_noise


def _brute_intervals(shape, line, lo, hi, axis):
    out = np.zeros(shape, bool)
    for ln, a, b in zip(line, np.rint(lo), np.rint(hi)):
        a, b = int(max(a, 0)), int(b)
        if b < a:
            continue  # empty, or entirely before the image
        if axis == 1 and 0 <= ln < shape[0]:
            out[ln, a : b + 1] = True
        if axis == 0 and 0 <= ln < shape[1]:
            out[a : b + 1, ln] = True
    return out


@pytest.mark.parametrize("axis", [0, 1])
def test_fill_intervals_matches_brute_force(axis):
    rng = np.random.default_rng(0)
    shape = (23, 31)
    n_lines = shape[0] if axis == 1 else shape[1]
    line = rng.integers(-2, n_lines + 2, 200)
    lo = rng.uniform(-5, 40, 200)
    hi = lo + rng.uniform(-3, 15, 200)  # some empty (hi < lo)
    got = fill_intervals(shape, line, lo, hi, axis=axis)
    np.testing.assert_array_equal(got, _brute_intervals(shape, line, lo, hi, axis))


def test_fill_intervals_empty_input():
    assert not fill_intervals((4, 5), [], [], []).any()


def _distance_to_segment(Y, X, p0, p1):
    d = p1 - p0
    t = np.clip(((Y - p0[0]) * d[0] + (X - p0[1]) * d[1]) / max(d @ d, 1e-12), 0, 1)
    return np.hypot(Y - p0[0] - t * d[0], X - p0[1] - t * d[1])


def test_capsules_match_distance_to_segment():
    rng = np.random.default_rng(1)
    shape = (40, 50)
    Y, X = np.mgrid[: shape[0], : shape[1]].astype(float)
    for k in range(100):
        p0 = rng.uniform(-5, 55, 2)
        p1 = p0 + rng.normal(0, 15, 2)
        if k % 10 == 0:
            p1[0] = p0[0]  # horizontal
        if k % 10 == 1:
            p1 = p0.copy()  # a dot
        r = rng.uniform(0.5, 7)
        row, lo, hi, cap = capsule_intervals(p0[None], p1[None], np.array([r]))
        assert np.all(cap == 0)
        got = fill_intervals(shape, row, lo, hi)
        dist = _distance_to_segment(Y, X, p0, p1)
        # Interval ends are rounded to whole pixels: disagreement only at the rim.
        assert not np.any((got != (dist <= r)) & (np.abs(dist - r) > 1.0))


def test_discs_match_distance_to_centre():
    shape = (30, 30)
    Y, X = np.mgrid[:30, :30].astype(float)
    cy, cx, r = np.array([5.0, 20.3]), np.array([7.0, 14.6]), np.array([3.0, 6.5])
    row, lo, hi, disc = disc_intervals(cy, cx, r)
    got = fill_intervals(shape, row, lo, hi)
    dist = np.minimum(np.hypot(Y - 5, X - 7) - 3, np.hypot(Y - 20.3, X - 14.6) - 6.5)
    assert not np.any((got != (dist <= 0)) & (np.abs(dist) > 1.0))
    assert set(np.unique(disc)) == {0, 1}


def test_smooth_noise_shape_dtype_and_smoothness():
    f = smooth_noise((64, 96), np.random.default_rng(0), cell=16)
    assert f.shape == (64, 96) and f.dtype == np.float32
    # Neighbouring pixels are strongly correlated (a smooth field, not white noise).
    assert np.corrcoef(f[:, :-1].ravel(), f[:, 1:].ravel())[0, 1] > 0.9
