"""Bootstrap intervals of per-frame means."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from inpaintenv.benchmark import bootstrap_mean_ci, bootstrap_ratio_ci


def test_interval_contains_mean_and_shrinks_with_more_frames():
    rng = np.random.default_rng(0)
    small = rng.normal(5.0, 2.0, 20)
    large = rng.normal(5.0, 2.0, 2000)
    m1, lo1, hi1 = bootstrap_mean_ci(small)
    m2, lo2, hi2 = bootstrap_mean_ci(large)
    assert lo1 <= m1 <= hi1 and lo2 <= m2 <= hi2
    assert (hi2 - lo2) < (hi1 - lo1) / 4
    # ~ 1.96 * sigma / sqrt(n) for a normal sample
    assert (hi2 - lo2) / 2 == pytest.approx(1.96 * 2.0 / np.sqrt(2000), rel=0.2)


def test_nan_frames_are_dropped_and_result_is_reproducible():
    vals = [1.0, np.nan, 3.0, 5.0]
    assert bootstrap_mean_ci(vals)[0] == pytest.approx(3.0)
    assert bootstrap_mean_ci(vals) == bootstrap_mean_ci(vals)


def test_degenerate_inputs():
    mean, low, high = bootstrap_mean_ci([2.0])  # one frame: no interval, not a zero-width one
    assert mean == 2.0 and np.isnan(low) and np.isnan(high)
    assert all(np.isnan(v) for v in bootstrap_mean_ci([np.nan]))
    with pytest.raises(ValueError, match="confidence"):
        bootstrap_mean_ci([1.0, 2.0], confidence=1.5)


def test_ratio_interval_is_paired():
    rng = np.random.default_rng(1)
    b = rng.uniform(2, 20, 40)  # frames differ a lot in difficulty
    a = 0.8 * b * rng.uniform(0.97, 1.03, 40)  # the first method is ~0.8x on every frame
    ratio, low, high = bootstrap_ratio_ci(a, b)
    assert ratio == pytest.approx(a.mean() / b.mean())
    assert low <= ratio <= high and high - low < 0.05  # pairing removes the frame spread
    assert bootstrap_ratio_ci(a, b) == bootstrap_ratio_ci(a, b)


def test_ratio_degenerate_and_bad_inputs():
    ratio, low, high = bootstrap_ratio_ci([3.0], [4.0])
    assert ratio == 0.75 and np.isnan(low) and np.isnan(high)
    with pytest.raises(ValueError, match="paired"):
        bootstrap_ratio_ci([1.0, 2.0], [1.0])
    with pytest.raises(ValueError, match="paired"):
        bootstrap_ratio_ci([], [])
    with pytest.raises(ValueError, match="confidence"):
        bootstrap_ratio_ci([1.0, 2.0], [1.0, 2.0], confidence=0.0)


def test_ratio_to_a_mean_of_zero_is_undefined_without_a_warning():
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # numpy's "divide by zero" must not be how it is found out
        assert all(np.isnan(v) for v in bootstrap_ratio_ci([1.0, 2.0], [0.0, 0.0]))
        ratio, low, high = bootstrap_ratio_ci([1.0, 2.0, 3.0], [0.0, 0.0, 1.0])  # some resamples draw only zeros
    assert ratio == pytest.approx(6.0) and np.isnan(low) and np.isnan(high)
