"""One look for every figure: colour maps, holes, method colours."""

from __future__ import annotations

import numpy as np
import pytest

from inpaintenv.report import style
from inpaintenv.envs.render import (
    COLORBAR_HEIGHT,
    LABEL_HEIGHT,
    colorize_depth,
    render_panel,
)


def _lab(rgb: np.ndarray) -> np.ndarray:
    """sRGB in [0, 1] -> CIELAB (D65)."""
    c = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
    xyz = c @ np.array([[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722], [0.0193, 0.1192, 0.9505]]).T
    xyz = xyz / np.array([0.95047, 1.0, 1.08883])
    f = np.where(xyz > 0.008856, np.cbrt(xyz), 7.787 * xyz + 16 / 116)
    return np.stack([116 * f[..., 1] - 16, 500 * (f[..., 0] - f[..., 1]), 200 * (f[..., 1] - f[..., 2])], -1)


def test_twenty_methods_get_distinct_colours_in_run_order():
    names = [f"m{i}" for i in range(20)]
    colours = style.method_colours(names)
    lab = _lab(np.array([colours[n] for n in names]))
    dist = np.linalg.norm(lab[:, None] - lab[None], axis=-1) + np.eye(20) * 1e9
    assert dist.min() > 25  # no two look alike (the old cycle repeated after 10: six pairs of 16 shared one)
    assert style.method_colours(names) == colours  # deterministic
    assert style.method_colours(["x", *names])["m0"] == colours["m1"]  # assigned in the run's order
    more = style.method_colours([*names, "extra-a", "extra-b"])
    assert more["extra-a"] == style.method_colours([*names, "extra-a"])["extra-a"]  # stable fallback


def test_depth_map_is_perceptually_ordered_near_bright_far_dark_and_no_data_grey():
    # One perceptually uniform map (viridis reversed): lightness falls steadily with depth.
    depths = np.linspace(1.0, 79.0, 40, dtype=np.float32)[None]
    lab = _lab(colorize_depth(depths, 80.0)[0] / 255.0)
    assert (np.diff(lab[:, 0]) < 0).all()  # near = bright, far = dark, no turn back (turbo's lightness turns)
    rgb = colorize_depth(np.array([[2.0, 75.0, 0.0]], np.float32), 80.0).astype(int)
    near, far, none = rgb[0]
    assert near.sum() > far.sum() + 200
    assert (none == style.to_uint8(np.array(style.NO_DATA))).all()
    assert (style.to_uint8(style.depth_rgb(np.array([[2.0]]), 80.0))[0, 0] == near).all()


def _frame():
    rng = np.random.default_rng(0)
    gt = rng.uniform(5.0, 40.0, (60, 200)).astype(np.float32)
    gt[::3] = 0.0  # rows without ground truth, as in LiDAR
    hole = np.zeros(gt.shape, bool)
    hole[10:40, 50:150] = True
    return gt, hole


def test_show_panel_hatches_holes_and_has_colour_bars():
    gt, hole = _frame()
    pred = gt + np.float32(1.0)
    panel = render_panel(gt, hole, pred)
    h, w = gt.shape
    assert panel.shape == (4 * (h + LABEL_HEIGHT) + 2 * COLORBAR_HEIGHT, w, 3)
    inp = panel[LABEL_HEIGHT : LABEL_HEIGHT + h]
    inside = inp[15:35, 55:145].reshape(-1, 3)
    colours = {tuple(c) for c in inside}
    # Hatched (two greys), not the old flat grey (90, 90, 90) nor red.
    assert colours == {tuple(style.to_uint8(np.array(style.NO_DATA))), tuple(style.to_uint8(np.array(style.HATCH)))}
    edge = tuple(style.to_uint8(np.array(style.HOLE_EDGE)))
    assert tuple(inp[10, 100]) == edge and tuple(inp[25, 50]) == edge  # outlined
    # A colour bar of the depth map under the depth tiles.
    bar = panel[3 * (h + LABEL_HEIGHT) : 3 * (h + LABEL_HEIGHT) + COLORBAR_HEIGHT]
    lut = style.to_uint8(style.lookup_table(style.DEPTH_CMAP))
    row = bar[8, 4]
    assert np.abs(row.astype(int) - lut[0]).max() <= 2


def test_error_tile_uses_its_scale():
    # Errors of 0-2 m on the old fixed 10 m scale (max_depth / 8) were nearly black; the
    # default scale is now a robust maximum of the errors shown.
    gt, hole = _frame()
    err = np.random.default_rng(1).uniform(0.0, 2.0, gt.shape).astype(np.float32)
    scored = hole & (gt > 0)
    assert style.error_scale(err[scored]) == pytest.approx(2.0)
    panel = render_panel(gt, hole, gt + err)
    assert np.array_equal(panel, render_panel(gt, hole, gt + err, error_max=2.0))
    h = gt.shape[0]
    tile = panel[-COLORBAR_HEIGHT - h : -COLORBAR_HEIGHT].astype(float)  # the error tile, above its colour bar
    assert tile[scored].mean() > 100  # mid-range magma, not black


@pytest.mark.parametrize(("values", "expected"), [([0.3, 0.9, 1.7], 2.0), ([12.0] * 5, 15.0), ([], 1.0)])
def test_error_scale_rounds_a_robust_maximum(values, expected):
    assert style.error_scale(np.array(values)) == pytest.approx(expected)
