"""render_panel: colour mapping, layout, argument checks and the kept figures."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from inpaintenv.envs import render
from inpaintenv.envs.render import (
    COLORBAR_HEIGHT,
    LABEL_HEIGHT,
    colorize_depth,
    colorize_error,
    render_panel,
)
from inpaintenv.report import plots, style
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


def _frames(n, shape=(24, 40), seed=0):
    rng = np.random.default_rng(seed)
    out = []
    for k in range(n):
        gt = np.where(rng.random(shape) < 0.5, rng.uniform(1.0, 90.0, shape), 0.0).astype(np.float32)
        gt[0, 0] = np.nan
        hole = np.zeros(shape, bool)
        hole[4 + k : 14, 6 : 20 + k] = True
        out.append((gt, hole, gt + rng.normal(0.0, 1.0 + 4 * k, shape).astype(np.float32)))
    return out


def test_colorize_is_the_style_colours_in_uint8():
    gt, hole, pred = _frames(1)[0]
    assert np.array_equal(colorize_depth(pred, 50.0), to_uint8(style.depth_rgb(pred, 50.0)))
    err = np.abs(pred - gt)
    assert np.array_equal(colorize_error(err, hole, 3.0), to_uint8(style.error_rgb(err, hole, 3.0)))


def test_a_panel_of_a_kept_layout_reuses_its_figure_and_draws_as_a_fresh_one(monkeypatch):
    made = []
    image_figure = plots.image_figure
    monkeypatch.setattr(plots, "image_figure", lambda *a, **k: (made.append(a), image_figure(*a, **k))[1])
    monkeypatch.setattr(render, "_PANELS", type(render._PANELS)())
    (a, ha, pa), (b, hb, pb), (c, hc, pc) = _frames(3)
    render_panel(a, ha, pa, title="step 0")
    reused = render_panel(b, hb, pb, title="step 1")
    again = render_panel(c, hc, pc, title="step 2", error_max=0.5)  # another error scale: its own colour bar
    assert len(made) == 1  # one figure for the three frames of one size and layout
    assert np.array_equal(render_panel(b, hb, pb, title="step 1"), reused)  # the first scale's bar shown again
    render._PANELS.clear()
    assert np.array_equal(render_panel(b, hb, pb, title="step 1"), reused)  # as a fresh figure draws it
    render._PANELS.clear()
    assert np.array_equal(render_panel(c, hc, pc, title="step 2", error_max=0.5), again)
    assert len(made) == 3
    render_panel(c, hc, None, title=["two", "lines"])  # another layout, another figure
    render_panel(c[:-1], hc[:-1], None)
    assert len(made) == 5 and len(render._PANELS) <= render.KEPT_LAYOUTS


def test_threads_drawing_panels_at_once_get_each_their_own_panel():
    frames = _frames(4, seed=1)
    expected = [render_panel(gt, hole, pred, title=f"frame {k}") for k, (gt, hole, pred) in enumerate(frames)]
    with ThreadPoolExecutor(4) as pool:
        got = list(pool.map(lambda k: render_panel(*frames[k % 4], title=f"frame {k % 4}"), range(16)))
    assert all(np.array_equal(g, expected[k % 4]) for k, g in enumerate(got))
