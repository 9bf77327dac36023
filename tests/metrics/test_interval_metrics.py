"""Interval metrics (inpaintenv.metrics) against a plain loop recomputation."""

from __future__ import annotations

from statistics import NormalDist

import cv2
import numpy as np
import pytest

from inpaintenv.exceptions import InvalidInputError, InvalidTypeError
from inpaintenv.metrics import (
    INTERVAL_COLUMNS,
    KEEP_GRID,
    border_distance,
    check_interval,
    interval_from_std,
    interval_metrics,
    normal_quantile,
)


def _frames(n: int = 3, seed: int = 0):
    rng = np.random.default_rng(seed)
    gt = rng.uniform(3, 60, (n, 24, 40)).astype(np.float32)
    gt[rng.random(gt.shape) < 0.3] = 0  # semi-dense truth
    hole = np.zeros(gt.shape, bool)
    hole[:, 5:19, 8:33] = True
    pred = np.abs(gt + rng.normal(0, 3, gt.shape)).astype(np.float32) + 0.5
    # Widths on a coarse grid, so ties occur, loosely following the error.
    half = np.round(np.abs(pred - gt) * rng.uniform(0.5, 2.0, gt.shape)).astype(np.float32)
    low, high = np.maximum(pred - half, 0), pred + half
    return pred, gt, hole, low, high


def _loop_curve(err2: list[float], score: list[float], fraction: float) -> float:
    """RMSE of the kept fraction with ties split in proportion, by a plain loop over tie groups."""
    groups: dict[float, list[float]] = {}
    for e, s in zip(err2, score):
        groups.setdefault(s, []).append(e)
    k = fraction * len(err2)
    left, sse = k, 0.0
    for s in sorted(groups):
        g = groups[s]
        take = min(left, len(g))
        sse += take * (sum(g) / len(g))
        left -= take
        if left <= 0:
            break
    return (sse / k) ** 0.5


def _loop_metrics(pred, gt, hole, low, high):
    out = {c: [] for c in INTERVAL_COLUMNS}
    dist = [cv2.distanceTransform(h.astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE) for h in hole]
    for k in range(len(gt)):
        cov, wid, err2, width, border = [], [], [], [], []
        for y in range(gt.shape[1]):
            for x in range(gt.shape[2]):
                if not (hole[k, y, x] and gt[k, y, x] > 0):
                    continue
                g, lo, hi, p = float(gt[k, y, x]), float(low[k, y, x]), float(high[k, y, x]), float(pred[k, y, x])
                cov.append(lo <= g <= hi)
                wid.append(hi - lo)
                err2.append((p - g) ** 2)
                width.append(round(hi - lo, 3))
                border.append(round(float(dist[k][y, x]) ** 2))
        full = (sum(err2) / len(err2)) ** 0.5
        out["hole_coverage"].append(sum(cov) / len(cov))
        out["hole_interval_width"].append(sum(wid) / len(wid))
        for prefix, score in (("", width), ("border_", border), ("oracle_", err2)):
            curve = {f: _loop_curve(err2, score, f) for f in (*KEEP_GRID, 0.9, 0.8, 0.5)}
            for f in (0.9, 0.8, 0.5):
                if f"{prefix}rmse_keep_{round(f * 100)}" in out:
                    out[f"{prefix}rmse_keep_{round(f * 100)}"].append(curve[f])
            out[f"{prefix}rejection_auc"].append(sum(curve[f] for f in KEEP_GRID) / len(KEEP_GRID) / full)
        out["rmse_cut_80"].append(1 - out["rmse_keep_80"][-1] / full)
    return {c: np.array(v) for c, v in out.items()}


def test_metrics_equal_a_loop_recomputation():
    pred, gt, hole, low, high = _frames()
    got = interval_metrics(pred, gt, hole, low, high)
    want = _loop_metrics(pred, gt, hole, low, high)
    assert set(got) == set(INTERVAL_COLUMNS)
    for c in INTERVAL_COLUMNS:
        np.testing.assert_allclose(got[c], want[c], rtol=1e-9, atol=1e-12, err_msg=c)


def test_single_frame_matches_its_batch_row():
    pred, gt, hole, low, high = _frames()
    batch = interval_metrics(pred, gt, hole, low, high)
    one = interval_metrics(pred[1], gt[1], hole[1], low[1], high[1])
    for c in INTERVAL_COLUMNS:
        assert one[c].shape == () and one[c] == batch[c][1]


def test_interval_around_truth_covers_everything():
    pred, gt, hole, _, _ = _frames()
    low, high = np.maximum(np.minimum(pred, gt) - 1, 0), np.maximum(pred, gt) + 1
    m = interval_metrics(pred, gt, hole, low, high)
    np.testing.assert_array_equal(m["hole_coverage"], 1.0)


def test_constant_width_ranks_nothing():
    pred, gt, hole, _, _ = _frames()
    pred = pred + 5  # keeps pred - 2 above 0: every width is exactly 4
    m = interval_metrics(pred, gt, hole, pred - 2, pred + 2)
    np.testing.assert_allclose(m["rejection_auc"], 1.0, rtol=1e-12)
    np.testing.assert_allclose(m["rmse_keep_50"], m["rmse_keep_90"], rtol=1e-12)
    np.testing.assert_allclose(m["rmse_cut_80"], 0.0, atol=1e-12)


def test_oracle_is_the_lowest_curve():
    pred, gt, hole, low, high = _frames()
    m = interval_metrics(pred, gt, hole, low, high)
    assert np.all(m["oracle_rejection_auc"] <= m["rejection_auc"] + 1e-12)
    assert np.all(m["oracle_rejection_auc"] <= m["border_rejection_auc"] + 1e-12)


def test_border_baseline_on_a_synthetic_case():
    # Error grows with the distance to the hole border: keeping the nearest 50 % keeps the small errors.
    gt = np.full((40, 40), 100.0, np.float32)
    hole = np.zeros_like(gt, bool)
    hole[10:30, 10:30] = True
    dist = border_distance(hole)
    assert dist[10, 10] == 1.0 and dist[0, 0] == 0.0 and dist[19, 19] == dist.max()
    pred = gt + dist  # error = distance to the border
    wide = np.full_like(gt, 50.0)
    m = interval_metrics(pred, gt, hole, np.maximum(pred - wide, 0), pred + wide)
    kept = np.sort(dist[hole])[: len(dist[hole]) // 2]
    assert m["border_rmse_keep_50"] < m["rmse_keep_50"]
    np.testing.assert_allclose(m["border_rmse_keep_50"], np.sqrt(np.mean(kept**2)), rtol=1e-6)
    np.testing.assert_allclose(m["border_rejection_auc"], m["oracle_rejection_auc"], rtol=1e-12)


def test_frame_without_hole_truth_is_nan():
    pred, gt, hole, low, high = _frames(2)
    gt[0][hole[0]] = 0
    m = interval_metrics(pred, gt, hole, low, high)
    assert all(np.isnan(m[c][0]) and np.isfinite(m[c][1]) for c in INTERVAL_COLUMNS)


def test_std_interval_uses_the_normal_quantile():
    assert normal_quantile(0.9) == pytest.approx(NormalDist().inv_cdf(0.95))
    pred = np.array([[1.0, 10.0]], np.float32)
    low, high = interval_from_std(pred, np.array([[2.0, 1.0]], np.float32), 0.9)
    z = NormalDist().inv_cdf(0.95)
    np.testing.assert_allclose(low, [[0.0, 10 - z]])
    np.testing.assert_allclose(high, [[1 + 2 * z, 10 + z]])


@pytest.mark.parametrize("std", [np.nan, -1.0, np.inf])
def test_bad_std_is_refused(std):
    pred = np.ones((2, 2), np.float32)
    with pytest.raises(InvalidInputError, match="std"):
        interval_from_std(pred, np.full((2, 2), std, np.float32), 0.9)


@pytest.mark.parametrize("coverage", [0.0, 1.0, 1.5, -0.1])
def test_coverage_out_of_range_is_refused(coverage):
    with pytest.raises(InvalidInputError, match="coverage"):
        normal_quantile(coverage)


def test_coverage_of_wrong_type_is_refused():
    with pytest.raises(InvalidTypeError, match="coverage"):
        normal_quantile("0.9")


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda lo, hi, p: (hi, lo), "inverted"),
        (lambda lo, hi, p: (lo * np.nan, hi), "NaN"),
        (lambda lo, hi, p: (lo, hi + np.inf), "infinite"),
        (lambda lo, hi, p: (lo - 100, hi), "negative"),
        (lambda lo, hi, p: (p + 0.5, hi + 1), "does not hold the prediction"),
        (lambda lo, hi, p: (lo, p - 0.5), "inverted|does not hold"),
        (lambda lo, hi, p: (lo[:, :-1], hi[:, :-1]), "shape"),
        (lambda lo, hi, p: (lo, hi[0]), "shape"),
    ],
)
def test_bad_interval_is_refused(change, message):
    pred, gt, hole, low, high = _frames()
    pred = pred + 5
    low, high = change(pred - 2, pred + 2, pred)
    with pytest.raises(InvalidInputError, match=message):
        interval_metrics(pred, gt, hole, low, high)


def test_empty_interval_is_refused():
    empty = np.zeros((0, 0), np.float32)
    with pytest.raises(InvalidInputError, match="empty"):
        check_interval(empty, empty, empty, np.zeros((0, 0), bool))


def test_interval_outside_the_hole_is_not_read():
    pred, gt, hole, low, high = _frames()
    low, high = low.copy(), high.copy()
    low[~hole], high[~hole] = np.nan, -1.0
    interval_metrics(pred, gt, hole, low, high)  # no error: only the filled pixels are checked


def test_integer_bounds_are_refused():
    pred, gt, hole, low, high = _frames()
    with pytest.raises(InvalidTypeError):
        interval_metrics(pred, gt, hole, low.astype(np.int32), high)
