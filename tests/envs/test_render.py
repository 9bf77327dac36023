"""render_panel: colour mapping, layout and argument checks."""

from __future__ import annotations

import numpy as np
import pytest

from inpaintenv.envs.render import (
    COLORBAR_HEIGHT,
    LABEL_HEIGHT,
    colorize_depth,
    colorize_error,
    render_panel,
)
from inpaintenv.report.style import NO_DATA, to_uint8

GREY = to_uint8(np.array(NO_DATA))


def test_colorize_depth_grey_for_no_data():
    d = np.array([[0.0, 10.0], [40.0, np.nan]], np.float32)
    rgb = colorize_depth(d, 80.0)
    assert rgb.shape == (2, 2, 3) and rgb.dtype == np.uint8
    assert (rgb[0, 0] == GREY).all() and (rgb[1, 1] == GREY).all()
    assert rgb[0, 1].any() and not np.array_equal(rgb[0, 1], rgb[1, 0])


def test_colorize_error_masks_invalid():
    e = np.array([[1.0, 5.0]], np.float32)
    rgb = colorize_error(e, np.array([[True, False]]), 10.0)
    assert (rgb[0, 1] == GREY).all() and not (rgb[0, 0] == GREY).all()


def test_render_panel_layout():
    gt = np.full((20, 30), 10.0, np.float32)
    gt[:, :5] = 0.0
    hole = np.zeros((20, 30), bool)
    hole[5:10, 5:15] = True
    panel = render_panel(gt, hole, gt + 1.0, title=["a", "b"])
    tiles = 4 * (20 + LABEL_HEIGHT) + 2 * COLORBAR_HEIGHT
    assert panel.dtype == np.uint8 and panel.shape == (2 * (LABEL_HEIGHT + 2) + tiles, 30, 3)
    no_pred = render_panel(gt, hole)
    assert no_pred.shape == (tiles, 30, 3)
    # Reconstruction and error tiles are black without a reconstruction.
    tile = 20 + LABEL_HEIGHT
    error_top = 3 * tile + COLORBAR_HEIGHT + LABEL_HEIGHT
    assert not no_pred[2 * tile + LABEL_HEIGHT : 3 * tile].any()
    assert not no_pred[error_top : error_top + 20].any()
    assert render_panel(gt, hole, gt + 1.0)[error_top : error_top + 20].any()


def test_render_panel_bad_input():
    gt = np.ones((4, 5), np.float32)
    with pytest.raises(ValueError, match="shape"):
        render_panel(gt, np.zeros((4, 4), bool))
    with pytest.raises(ValueError, match="reconstruction"):
        render_panel(gt, np.zeros((4, 5), bool), np.ones((5, 4)))
    with pytest.raises(ValueError, match="max_depth"):
        render_panel(gt, np.zeros((4, 5), bool), max_depth=0)


@pytest.mark.parametrize("key", ["max_depth", "error_max"])
@pytest.mark.parametrize("value", [float("nan"), float("inf")])
def test_render_panel_refuses_non_finite_scales(key, value):
    # A NaN scale used to give an all-black panel without a word.
    gt = np.ones((4, 5), np.float32)
    with pytest.raises(ValueError, match=f"{key} must be a finite positive number of metres, got {value}"):
        render_panel(gt, np.zeros((4, 5), bool), **{key: value})
