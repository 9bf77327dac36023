"""The shared NaN / 0 / metres convention and its validation errors."""

from __future__ import annotations

import numpy as np
import pytest

from inpaintenv.conventions import check_depth, check_mask, corrupt


def test_corrupt_marks_holes_with_nan_and_keeps_input():
    gt = np.array([[1.0, 0.0], [3.0, 4.0]], dtype=np.float32)
    hole = np.array([[True, True], [False, False]])
    x = corrupt(gt, hole)
    assert x.dtype == np.float32
    assert np.isnan(x[0]).all() and (x[1] == gt[1]).all()
    assert not np.isnan(gt).any()


def test_check_depth_converts_integers_and_keeps_float32_without_copy():
    a = np.ones((2, 2), np.float32)
    assert check_depth(a) is a
    assert check_depth(np.ones((2, 2), np.uint16)).dtype == np.float32


@pytest.mark.parametrize(
    "value, error, message",
    [
        (np.ones(3), ValueError, "2-D"),
        (np.ones((0, 3)), ValueError, "empty"),
        (np.array([[1.0, np.inf]]), ValueError, "infinite"),
        (np.array([[1.0, np.nan]]), ValueError, "NaN"),
        (np.array([[1.0, -2.0]]), ValueError, "negative"),
        (np.array([["a"]]), TypeError, "numeric"),
        (np.ones((2, 2), bool), TypeError, "boolean"),
    ],
)
def test_check_depth_errors(value, error, message):
    with pytest.raises(error, match=message):
        check_depth(value)


def test_check_depth_allows_nan_when_asked():
    out = check_depth(np.array([[1.0, np.nan]]), allow_nan=True)
    assert np.isnan(out[0, 1])


def test_check_mask():
    assert check_mask(np.array([[0, 1]]), (1, 2)).dtype == bool
    with pytest.raises(ValueError, match="shape"):
        check_mask(np.ones((2, 2), bool), (1, 2))
    with pytest.raises(TypeError):
        check_mask(np.array([["x", "y"]]), (1, 2))
