"""The unmeasured-pixel metrics and KITTI's own four, against a float64 NumPy recomputation."""

from __future__ import annotations

import numpy as np
import pytest

from inpaintenv.exceptions import UnfilledPixelsError
from inpaintenv.metrics import EXTRA_COLUMNS, ScoredPixels, aggregate, frame_metrics


def _frames(seed: int, n: int = 3, shape: tuple[int, int] = (24, 40)):
    """Ground truth (70 % valid), a scan (some of its pixels, a few outside it), a hole, a prediction."""
    rng = np.random.default_rng(seed)
    gt = rng.uniform(1.0, 80.0, (n, *shape)).astype(np.float32)
    gt[rng.random(gt.shape) < 0.3] = 0.0
    scan = np.where(rng.random(gt.shape) < 0.1, rng.uniform(1.0, 80.0, gt.shape), 0.0).astype(np.float32)
    on_truth = (gt > 0) & (rng.random(gt.shape) < 0.05)
    scan[on_truth] = gt[on_truth]
    hole = np.zeros(gt.shape, bool)
    hole[:, 5:15, 10:30] = True
    pred = (gt + rng.normal(0.0, 2.0, gt.shape)).clip(0.5, 90.0).astype(np.float32)
    return pred, gt, scan, hole


def _devkit(pred: np.ndarray, gt: np.ndarray) -> dict[str, float]:
    """KITTI depth completion's four on one frame (devkit evaluate_depth.cpp), float64: mm and 1/km."""
    valid = gt > 0
    p, g = pred[valid].astype(np.float64), gt[valid].astype(np.float64)
    err_mm = (p - g) * 1000.0
    inv_km = (1.0 / p - 1.0 / g) * 1000.0
    return {"kitti_rmse": np.sqrt(np.mean(err_mm**2)), "kitti_mae": np.mean(np.abs(err_mm)),
            "kitti_irmse": np.sqrt(np.mean(inv_km**2)), "kitti_imae": np.mean(np.abs(inv_km))}


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_kitti_four_equal_the_devkit_formulas(seed):
    pred, gt, scan, hole = _frames(seed)
    m = frame_metrics(pred, gt, hole, inputs=scan)
    for k in range(len(gt)):
        want = _devkit(pred[k], gt[k])
        for key, value in want.items():
            np.testing.assert_allclose(m[key][k], value, rtol=1e-12)


@pytest.mark.parametrize("seed", [0, 1])
def test_unmeasured_pixels_are_the_truth_the_input_lacks(seed):
    pred, gt, scan, hole = _frames(seed)
    m = frame_metrics(pred, gt, hole, inputs=scan)
    for k in range(len(gt)):
        unmeasured = (gt[k] > 0) & ((scan[k] == 0) | hole[k])
        e = pred[k][unmeasured].astype(np.float64) - gt[k][unmeasured].astype(np.float64)
        assert m["unmeasured_count"][k] == unmeasured.sum() > m["hole_count"][k] > 0
        np.testing.assert_allclose(m["unmeasured_rmse"][k], np.sqrt(np.mean(e**2)), rtol=1e-12)
        np.testing.assert_allclose(m["unmeasured_mae"][k], np.mean(np.abs(e)), rtol=1e-12)
        np.testing.assert_allclose(m["unmeasured_psnr"][k], 20 * np.log10(80.0 / np.sqrt(np.mean(e**2))), rtol=1e-12)


def test_for_a_map_input_the_unmeasured_pixels_are_the_hole_and_old_columns_are_unchanged():
    pred, gt, scan, hole = _frames(3)
    plain = frame_metrics(pred, gt, hole)
    with_scan = frame_metrics(pred, gt, hole, inputs=scan)
    for m in ("rmse", "mae", "psnr", "count"):
        np.testing.assert_array_equal(plain[f"unmeasured_{m}"], plain[f"hole_{m}"])
    # The input changes only the unmeasured columns.
    for key in plain:
        if not key.startswith("unmeasured_"):
            np.testing.assert_array_equal(plain[key], with_scan[key])
    assert set(EXTRA_COLUMNS) <= set(plain)


def test_scored_pixels_count_the_unmeasured_pixels():
    _, gt, scan, hole = _frames(4)
    scored = ScoredPixels(gt, hole, inputs=scan)
    np.testing.assert_array_equal(scored.unmeasured_count, ((gt > 0) & ((scan == 0) | hole)).sum(axis=(1, 2)))
    with pytest.raises(ValueError, match="inputs has shape"):
        ScoredPixels(gt, hole, inputs=scan[:1])


def test_densify_scores_unmeasured_pixels_and_leaves_the_hole_empty():
    pred, gt, scan, _ = _frames(5)
    no_hole = np.zeros(gt.shape, bool)
    m = frame_metrics(pred, gt, no_hole, inputs=scan)
    assert np.all(m["hole_count"] == 0) and np.all(np.isnan(m["hole_rmse"]))
    assert np.all(m["unmeasured_count"] > 0)
    # Every frame's hole is empty: with the default task all means are NaN, with task="unmeasured" they are not.
    table = aggregate(m, task="unmeasured")
    assert table["n_skipped_hole"] == 0 and np.isnan(table["hole_rmse"])
    np.testing.assert_allclose(table["unmeasured_rmse"], np.mean(m["unmeasured_rmse"]), rtol=1e-12)
    np.testing.assert_allclose(table["all_rmse"], np.mean(m["all_rmse"]), rtol=1e-12)
    assert aggregate(m)["n_skipped_hole"] == len(gt)


def test_kitti_means_are_over_every_frame_as_the_devkit_averages():
    pred, gt, scan, hole = _frames(6)
    hole[0] = False  # frame 0 tests nothing: it leaves the hole and all means, not KITTI's
    m = frame_metrics(pred, gt, hole, inputs=scan)
    table = aggregate(m)
    assert table["n_skipped_hole"] == 1
    np.testing.assert_allclose(table["kitti_rmse"], np.mean(m["kitti_rmse"]), rtol=1e-12)
    np.testing.assert_allclose(table["all_rmse"], np.mean(m["all_rmse"][1:]), rtol=1e-12)
    pooled = aggregate(m, how="pooled")
    want = np.sqrt(np.sum(m["kitti_rmse"] ** 2 * m["all_count"]) / np.sum(m["all_count"]))
    np.testing.assert_allclose(pooled["kitti_rmse"], want, rtol=1e-12)


def test_an_unfilled_unmeasured_pixel_is_refused_outside_the_hole_too():
    pred, gt, scan, hole = _frames(7)
    outside = (gt > 0) & (scan == 0) & ~hole
    pred[outside.nonzero()[0][0], outside.nonzero()[1][0], outside.nonzero()[2][0]] = 0.0
    with pytest.raises(UnfilledPixelsError, match="1 unmeasured pixels"):
        frame_metrics(pred, gt, hole, inputs=scan)
    frame_metrics(pred, gt, hole)  # for a map input that pixel was given: scored as given


def test_aggregate_refuses_an_unknown_task():
    pred, gt, _, hole = _frames(8)
    with pytest.raises(ValueError, match="task"):
        aggregate(frame_metrics(pred, gt, hole), task="scan")
