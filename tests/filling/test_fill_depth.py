"""``inpaintenv.filling.fill_depth``: one depth map filled in memory, as ``fill`` fills each file.

Its refusals of bad arrays are in ``tests/cli/test_cli_fill_safety.py`` and
``tests/security/test_entry_points.py``.
"""

from __future__ import annotations

import numpy as np
import pytest

from estimators.classical import NearestInpainter, ScanlineInpainter
from inpaintenv.data import SyntheticStreets
from inpaintenv.filling import fill_depth


@pytest.fixture
def depth() -> np.ndarray:
    return SyntheticStreets(n=1, frame_shape=(40, 96), kind="velodyne_raw", seed=5)[0]


def _box() -> np.ndarray:
    mask = np.zeros((40, 96), bool)
    mask[10:25, 20:60] = True
    return mask


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_measured_pixels_stay_filled_ones_are_positive_in_the_inputs_dtype(depth, dtype):
    d = depth.astype(dtype)
    before = d.copy()
    got = fill_depth("scanline", d, _box())
    assert got.dtype == dtype and got.shape == d.shape
    np.testing.assert_array_equal(d, before)  # the input is not written to
    np.testing.assert_array_equal(got[~_box()], d[~_box()])  # measured kept, unmeasured still 0
    assert (got[_box()] > 0).all() and np.isfinite(got).all()


def test_nan_pixels_and_the_mask_add_up(depth):
    d = depth.copy()
    d[:5] = np.nan
    got = fill_depth("nearest", d, _box())
    both = _box().copy()
    both[:5] = True
    np.testing.assert_array_equal(got, fill_depth("nearest", np.where(both, np.nan, depth)))
    assert (got[both] > 0).all()


@pytest.mark.parametrize("name, estimator", [("nearest", NearestInpainter()),
                                             ("scanline", ScanlineInpainter())])
def test_a_name_and_its_estimator_fill_alike(depth, name, estimator):
    np.testing.assert_array_equal(fill_depth(name, depth, _box()), fill_depth(estimator, depth, _box()))


def test_a_callable_is_given_nan_where_to_fill(depth):
    seen = []

    def constant(x: np.ndarray) -> np.ndarray:
        seen.append(np.isnan(x))
        return np.where(np.isnan(x), 7.0, x)

    got = fill_depth(constant, depth, _box())
    assert seen and all(s.shape[-2:] == (40, 96) for s in seen)
    np.testing.assert_array_equal(seen[-1].reshape(40, 96), _box())
    assert (got[_box()] == 7.0).all()
