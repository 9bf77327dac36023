"""Metrics against a plain-Python reference, conventions and aggregation rules."""

from __future__ import annotations

import math

import numpy as np
import pytest

from inpaintenv.exceptions import UnfilledPixelsError
from inpaintenv.metrics import (
    ScoredPixels,
    aggregate,
    depth_binned_errors,
    frame_metrics,
    interpolate_background,
)


def reference_metrics(pred, gt, hole, max_depth=80.0):
    """Pixel-by-pixel loops, the slow obvious way."""
    out = {}
    H, W = gt.shape
    for region in ("hole", "all"):
        se = ae = ise = iae = 0.0
        n = 0
        for i in range(H):
            for j in range(W):
                g = float(gt[i, j])
                if g <= 0 or (region == "hole" and not hole[i, j]):
                    continue
                p = float(pred[i, j])
                n += 1
                se += (p - g) ** 2
                ae += abs(p - g)
                ie = 1000.0 / max(p, 0.1) - 1000.0 / g
                ise += ie**2
                iae += abs(ie)
        if n == 0:
            out.update({f"{region}_{m}": math.nan for m in ("rmse", "mae", "irmse", "imae", "psnr")})
        else:
            rmse = math.sqrt(se / n)
            out[f"{region}_rmse"] = rmse
            out[f"{region}_mae"] = ae / n
            out[f"{region}_irmse"] = math.sqrt(ise / n)
            out[f"{region}_imae"] = iae / n
            out[f"{region}_psnr"] = 20 * math.log10(max_depth / rmse)
        out[f"{region}_count"] = n
    return out


def random_case(rng, shape=(8, 9)):  # batches of frames need >= MIN_FRAME_SIDE (8) px
    gt = rng.uniform(1, 60, shape).astype(np.float32)
    gt[rng.random(shape) < 0.4] = 0.0
    pred = np.abs(gt + rng.normal(0, 3, shape)).astype(np.float32)
    hole = rng.random(shape) < 0.5
    return pred, gt, hole


@pytest.mark.parametrize("seed", range(5))
def test_single_frame_matches_reference(seed):
    pred, gt, hole = random_case(np.random.default_rng(seed))
    got = frame_metrics(pred, gt, hole)
    want = reference_metrics(pred, gt, hole)
    for key, value in want.items():
        assert got[key] == pytest.approx(value, rel=1e-9, nan_ok=True), key


def test_batch_equals_per_frame():
    rng = np.random.default_rng(1)
    cases = [random_case(rng) for _ in range(4)]
    pred, gt, hole = (np.stack(c) for c in zip(*cases))
    batch = frame_metrics(pred, gt, hole)
    for k, (p, g, h) in enumerate(cases):
        single = frame_metrics(p, g, h)
        for key in single:
            np.testing.assert_allclose(batch[key][k], single[key])


def test_scored_pixels_score_like_frame_metrics_and_the_reference():
    rng = np.random.default_rng(4)
    cases = [random_case(rng, (12, 17)) for _ in range(3)]
    pred, gt, hole = (np.stack(c) for c in zip(*cases))
    gt[1] = 0.0  # a frame without ground truth: NaN metrics, zero counts
    hole[2] = False  # a frame without a hole: NaN hole metrics
    scored = ScoredPixels(gt, hole)
    np.testing.assert_array_equal(scored.all_count, (gt > 0).sum(axis=(1, 2)))
    np.testing.assert_array_equal(scored.hole_count, ((gt > 0) & hole).sum(axis=(1, 2)))
    for max_depth in (80.0, 50.0):
        got = scored.metrics(pred, max_depth=max_depth)  # scored twice from one gather
        batch = frame_metrics(pred, gt, hole, max_depth=max_depth)
        for key in batch:
            np.testing.assert_array_equal(got[key], batch[key])
        for k in range(3):
            want = reference_metrics(pred[k], gt[k], hole[k], max_depth=max_depth)
            for key, value in want.items():
                assert got[key][k] == pytest.approx(value, rel=1e-9, nan_ok=True), (k, key)
    single = ScoredPixels(gt[0], hole[0])
    assert single.all_count == scored.all_count[0] and single.metrics(pred[0])["hole_rmse"].shape == ()


def test_scored_pixels_check_their_inputs():
    ok = np.ones((3, 3), np.float32)
    with pytest.raises(ValueError, match="NaN"):
        ScoredPixels(np.full((3, 3), np.nan, np.float32), np.ones((3, 3), bool))
    with pytest.raises(ValueError, match="mask"):
        ScoredPixels(ok, np.ones((2, 3), bool))
    scored = ScoredPixels(ok, np.ones((3, 3), bool))
    with pytest.raises(ValueError, match="shape"):
        scored.metrics(np.ones((3, 4), np.float32))
    with pytest.raises(TypeError, match="numeric"):
        scored.metrics(np.full((3, 3), "a"))
    with pytest.raises(ValueError, match="NaN or inf"):
        scored.metrics(np.where(np.eye(3, dtype=bool), np.inf, 1.0))
    with pytest.raises(ValueError, match="negative"):
        scored.metrics(np.where(np.eye(3, dtype=bool), -1.0, 1.0))
    with pytest.raises(ValueError, match="max_depth"):
        scored.metrics(ok, max_depth=float("nan"))


def test_pixels_without_ground_truth_do_not_count():
    gt = np.array([[10.0, 0.0], [20.0, 0.0]], dtype=np.float32)
    pred = np.array([[11.0, 500.0], [20.0, 0.0]], dtype=np.float32)
    hole = np.array([[True, True], [False, True]])
    m = frame_metrics(pred, gt, hole)
    assert m["hole_rmse"] == pytest.approx(1.0)
    assert m["hole_count"] == 1
    assert m["all_rmse"] == pytest.approx(math.sqrt(0.5))
    assert m["all_psnr"] == pytest.approx(20 * math.log10(80 / math.sqrt(0.5)))


def test_psnr_uses_max_depth_and_is_finite_for_perfect_prediction():
    gt = np.full((4, 4), 10.0, dtype=np.float32)
    hole = np.zeros((4, 4), bool)
    hole[:2] = True
    m = frame_metrics(gt, gt, hole, max_depth=100.0)
    assert m["hole_rmse"] == 0.0
    assert np.isfinite(m["hole_psnr"]) and m["hole_psnr"] > 100
    m2 = frame_metrics(gt + 1, gt, hole, max_depth=100.0)
    assert m2["hole_psnr"] == pytest.approx(40.0)


def test_frames_without_hole_ground_truth_are_skipped_in_the_mean():
    gt = np.full((2, 8, 8), 10.0, dtype=np.float32)
    gt[1, :2] = 0.0  # frame 1 has no ground truth where its hole is
    hole = np.zeros((2, 8, 8), bool)
    hole[:, :2] = True
    pred = gt + np.array([2.0, 5.0], dtype=np.float32)[:, None, None]
    per_frame = frame_metrics(pred, gt, hole)
    assert np.isnan(per_frame["hole_rmse"][1])
    table = aggregate(per_frame)
    assert table["n_frames"] == 2
    assert table["n_skipped_hole"] == 1
    assert table["hole_rmse"] == pytest.approx(2.0)
    # The skipped frame tested nothing, so it leaves the all-pixel mean too.
    assert table["all_rmse"] == pytest.approx(2.0)


def devkit_frame_errors(pred: np.ndarray, gt: np.ndarray) -> dict[str, float]:
    """One frame's errors by the KITTI devkit's depthError (evaluate_depth.cpp), in float64.

    Every pixel with ground truth counts; depth in m, inverse depth in 1/m; no clamp.
    """
    valid = gt > 0
    g, p = gt[valid].astype(np.float64), pred[valid].astype(np.float64)
    err, inv = np.abs(g - p), np.abs(1.0 / g - 1.0 / p)
    return {"mae": err.mean(), "rmse": math.sqrt((err**2).mean()), "imae": inv.mean(),
            "irmse": math.sqrt((inv**2).mean())}


def test_all_pixel_means_against_the_devkit_formulas():
    rng = np.random.default_rng(7)
    gt = rng.uniform(2, 70, (5, 16, 24)).astype(np.float32)
    gt[rng.random(gt.shape) < 0.6] = 0.0
    hole = np.zeros(gt.shape, bool)
    hole[:, 4:12, 6:18] = True
    gt[2, 4:12, 6:18] = 0.0  # frame 2: no ground truth in its hole
    # Predictions of at least 0.1 m, where our clamp before inversion changes nothing.
    pred = np.maximum(gt + rng.normal(0, 2, gt.shape), 0.5).astype(np.float32)
    devkit = [devkit_frame_errors(pred[k], gt[k]) for k in range(len(gt))]
    per_frame = frame_metrics(pred, gt, hole)
    units = {"rmse": 1.0, "mae": 1.0, "irmse": 1000.0, "imae": 1000.0}  # ours 1/km, the devkit's 1/m
    # Per frame: the devkit's formulas (float64), every frame.
    for m, scale in units.items():
        np.testing.assert_allclose(per_frame[f"all_{m}"], [d[m] * scale for d in devkit], rtol=1e-12)
    # The devkit averages every frame: all_frames="every" ...
    every = aggregate(per_frame, all_frames="every")
    # ... while by default the all-pixel means cover the frames of the hole means.
    scored = aggregate(per_frame)
    assert scored["n_skipped_hole"] == every["n_skipped_hole"] == 1
    for m, scale in units.items():
        assert every[f"all_{m}"] == pytest.approx(np.mean([d[m] for d in devkit]) * scale, rel=1e-12)
        assert scored[f"all_{m}"] == pytest.approx(np.mean([d[m] for k, d in enumerate(devkit) if k != 2]) * scale,
                                                   rel=1e-12)
    assert every["hole_rmse"] == scored["hole_rmse"]
    with pytest.raises(ValueError, match="all_frames must be 'scored' or 'every', got 'all'"):
        aggregate(per_frame, all_frames="all")


def devkit_interpolate(pred: np.ndarray) -> np.ndarray:
    """The devkit's interpolateBackground, pixel by pixel as io_depth.h describes it (0 = invalid)."""
    d = pred.astype(np.float64).copy()
    h, w = d.shape
    valid = d > 0
    for v in range(h):
        count = 0
        for u in range(w):
            if valid[v, u]:
                if count >= 1 and u - count > 0:
                    d[v, u - count : u] = min(d[v, u - count - 1], d[v, u])
                count = 0
            else:
                count += 1
        filled = np.flatnonzero(valid[v])
        if filled.size:
            d[v, : filled[0]] = d[v, filled[0]]
            d[v, filled[-1] + 1 :] = d[v, filled[-1]]
            valid[v] = True
    for u in range(w):
        filled = np.flatnonzero(valid[:, u])
        if filled.size:
            d[: filled[0], u] = d[filled[0], u]
            d[filled[-1] + 1 :, u] = d[filled[-1], u]
    return d


@pytest.mark.parametrize("seed", range(4))
def test_interpolate_background_is_the_devkit_s(seed):
    rng = np.random.default_rng(seed)
    pred = rng.uniform(1, 80, (2, 12, 17)).astype(np.float32)
    pred[rng.random(pred.shape) < [[[0.3]], [[0.9]]]] = 0.0
    pred[0, 3] = 0.0  # an empty row between filled ones stays empty
    pred[0, :2] = 0.0  # empty rows at the top take the first filled row
    pred[1, -1] = 0.0
    got = interpolate_background(pred)
    assert got.dtype == np.float32 and got.shape == pred.shape
    for k in range(2):
        np.testing.assert_array_equal(got[k], devkit_interpolate(pred[k]).astype(np.float32))
        np.testing.assert_array_equal(interpolate_background(pred[k]), got[k])
    assert (got[0, 3] == 0).all() and (got[0, 0] == got[0, 2]).all()
    np.testing.assert_array_equal(interpolate_background(np.zeros((8, 8))), 0.0)


def _unfilled_case():
    gt = np.full((2, 8, 10), 10.0, np.float32)
    hole = np.zeros(gt.shape, bool)
    hole[:, 2:5, 3:7] = True
    pred = gt.copy()
    pred[0, 2:5, 3:7] = 12.0
    pred[1, 3, 4:6] = 0.0  # two hole pixels left unfilled
    pred[1, 6, 0] = 0.0  # and one pixel outside the hole
    return pred, gt, hole


def test_unfilled_pixels_are_refused_with_a_count():
    # A 0 m hole pixel was scored as 0 m without a word (NaN was refused).
    pred, gt, hole = _unfilled_case()
    with pytest.raises(UnfilledPixelsError, match=r"^prediction is 0 m \(unfilled\) at 2 hole pixels with ground truth; "
                                                 r"fill them, or set unfilled to 'interpolate'"):
        frame_metrics(pred, gt, hole)
    with pytest.raises(UnfilledPixelsError, match="at 2 hole pixels"):
        ScoredPixels(gt, hole).metrics(pred)
    # 0 m where there is no ground truth is not scored, so not refused ...
    gt2 = gt.copy()
    gt2[pred == 0] = 0.0
    assert np.isfinite(frame_metrics(pred, gt2, hole)["hole_rmse"]).all()
    # ... and outside the hole (the method was given the measurement) it is scored as given.
    outside = gt.copy()
    outside[1, 6, 0] = 0.0
    assert frame_metrics(outside, gt, hole)["all_rmse"][1] == pytest.approx(10.0 / math.sqrt((gt[1] > 0).sum()))
    with pytest.raises(ValueError, match="unfilled must be one of 'error', 'interpolate', 'zero', got 'skip'"):
        frame_metrics(pred, gt, hole, unfilled="skip")


def test_unfilled_policies_zero_and_interpolate():
    pred, gt, hole = _unfilled_case()
    zero = frame_metrics(pred, gt, hole, unfilled="zero")
    assert zero["hole_rmse"][1] == pytest.approx(math.sqrt(2 * 10.0**2 / 12))
    ipol = frame_metrics(pred, gt, hole, unfilled="interpolate")
    want = frame_metrics(interpolate_background(pred), gt, hole)
    for k, v in want.items():
        np.testing.assert_array_equal(ipol[k], v)
    assert ipol["hole_rmse"][1] == 0.0  # the devkit fills the gaps from their neighbours (10 m)
    # Frame 0 has nothing unfilled: every policy scores it alike.
    assert zero["hole_rmse"][0] == ipol["hole_rmse"][0] == pytest.approx(2.0)


def test_pooled_aggregation_weights_pixels():
    gt = np.full((2, 8, 8), 10.0, dtype=np.float32)
    hole = np.zeros((2, 8, 8), bool)
    hole[0, :1] = True  # 8 pixels with error 1
    hole[1, :3] = True  # 24 pixels with error 3
    pred = gt + np.array([1.0, 3.0], dtype=np.float32)[:, None, None]
    pooled = aggregate(frame_metrics(pred, gt, hole), how="pooled")
    assert pooled["hole_rmse"] == pytest.approx(math.sqrt((8 * 1 + 24 * 9) / 32))
    assert pooled["hole_mae"] == pytest.approx((8 + 72) / 32)
    assert pooled["hole_psnr"] == pytest.approx(20 * math.log10(80 / pooled["hole_rmse"]))
    mean = aggregate(frame_metrics(pred, gt, hole))
    assert mean["hole_rmse"] == pytest.approx(2.0)


def test_aggregate_accepts_rows():
    gt = np.full((2, 8, 8), 5.0, dtype=np.float32)
    hole = np.ones((2, 8, 8), bool)
    per_frame = frame_metrics(gt + 1, gt, hole)
    rows = [{k: float(v[i]) for k, v in per_frame.items()} for i in range(2)]
    assert aggregate(rows) == aggregate(per_frame)


@pytest.mark.parametrize(
    "pred, message",
    [
        (np.full((3, 3), np.nan, np.float32), "NaN or inf"),
        (np.full((3, 3), -1.0, np.float32), "negative"),
        (np.ones((3, 4), np.float32), "shape"),
        (np.full((3, 3), "a"), "numeric"),
    ],
)
def test_bad_predictions_are_rejected(pred, message):
    gt = np.ones((3, 3), np.float32)
    with pytest.raises((ValueError, TypeError), match=message):
        frame_metrics(pred, gt, np.ones((3, 3), bool))


def test_nan_prediction_outside_ground_truth_is_ignored():
    gt = np.array([[1.0, 0.0]], dtype=np.float32)
    pred = np.array([[1.0, np.nan]], dtype=np.float32)
    assert frame_metrics(pred, gt, np.ones((1, 2), bool))["hole_rmse"] == 0.0


def test_bad_ground_truth_and_mask_are_rejected():
    ok = np.ones((3, 3), np.float32)
    with pytest.raises(ValueError, match="NaN"):
        frame_metrics(ok, np.full((3, 3), np.nan, np.float32), np.ones((3, 3), bool))
    with pytest.raises(ValueError, match="mask"):
        frame_metrics(ok, ok, np.ones((2, 3), bool))
    with pytest.raises(ValueError, match="only 0 and 1"):
        frame_metrics(ok, ok, np.full((3, 3), 2))
    with pytest.raises(ValueError, match="how"):
        aggregate(frame_metrics(ok, ok, np.ones((3, 3), bool)), how="median")


@pytest.mark.parametrize(
    "max_depth, error",
    [(float("nan"), ValueError), (float("inf"), ValueError), (0.0, ValueError), ("80", TypeError)],
)
def test_max_depth_must_be_finite_and_positive(max_depth, error):
    # NaN used to give NaN PSNR silently; "80" failed inside a comparison.
    ok = np.ones((3, 3), np.float32)
    with pytest.raises(error, match="max_depth must be a finite positive number of metres"):
        frame_metrics(ok, ok, np.ones((3, 3), bool), max_depth=max_depth)
    per_frame = frame_metrics(ok, ok, np.ones((3, 3), bool))
    with pytest.raises(error, match="max_depth must be a finite positive number of metres"):
        aggregate(per_frame, how="pooled", max_depth=max_depth)


def test_raw_png_codes_as_ground_truth_are_refused():
    raw = np.full((3, 3), 15359.0, np.float32)
    with pytest.raises(ValueError, match="divide by 256"):
        frame_metrics(np.ones((3, 3), np.float32), raw, np.ones((3, 3), bool))


def test_aggregate_refuses_columns_of_different_lengths():
    gt = np.full((2, 8, 8), 5.0, dtype=np.float32)
    per_frame = dict(frame_metrics(gt + 1, gt, np.ones((2, 8, 8), bool)))
    per_frame["hole_rmse"] = per_frame["hole_rmse"][:1]
    with pytest.raises(ValueError, match="one length"):
        aggregate(per_frame)


# -- depth_binned_errors -------------------------------------------------------------------


def _binned_case(seed=0):
    rng = np.random.default_rng(seed)
    gt = rng.uniform(1, 90, (2, 24, 32)).astype(np.float32)
    gt[rng.random(gt.shape) < 0.4] = 0  # semi-dense truth
    hole = np.zeros(gt.shape, bool)
    hole[:, 4:18, 5:25] = True
    pred = np.abs(gt + rng.normal(0, 3, gt.shape)).astype(np.float32)
    return pred, gt, hole


def test_depth_bins_recompose_the_pooled_hole_rmse():
    pred, gt, hole = _binned_case()
    rows = depth_binned_errors(pred, gt, hole)
    assert sum(r["pixels"] for r in rows) == np.count_nonzero(hole & (gt > 0))
    assert math.isclose(sum(r["pixel_share"] for r in rows), 1.0)
    assert math.isclose(sum(r["sse_share"] for r in rows), 1.0)
    pooled = aggregate(frame_metrics(pred, gt, hole), how="pooled")["hole_rmse"]
    recomposed = math.sqrt(sum(r["pixel_share"] * r["rmse"] ** 2 for r in rows if r["pixels"]))
    assert math.isclose(recomposed, pooled, rel_tol=1e-9)


def test_depth_bins_report_signed_bias_per_bin():
    gt = np.array([[5.0, 15.0, 60.0, 0.0]], np.float32)
    pred = np.array([[6.0, 15.0, 40.0, 99.0]], np.float32)  # the 0-truth pixel is not scored
    rows = depth_binned_errors(pred, gt, np.ones(gt.shape, bool), edges=(0, 10, 50, np.inf))
    assert [r["pixels"] for r in rows] == [1, 1, 1]
    assert [r["bias"] for r in rows] == [1.0, 0.0, -20.0]
    assert math.isclose(rows[2]["sse_share"], 400 / 401)


def test_depth_bins_empty_bin_is_nan_not_an_error():
    gt = np.full((4, 4), 5.0, np.float32)
    rows = depth_binned_errors(gt, gt, np.ones(gt.shape, bool), edges=(0, 10, 20))
    assert rows[0]["rmse"] == 0.0 and rows[0]["sse_share"] == 0.0
    assert rows[1]["pixels"] == 0 and math.isnan(rows[1]["rmse"]) and math.isnan(rows[1]["bias"])


@pytest.mark.parametrize(
    "change, match",
    [
        ({"hole": np.zeros((8, 8), bool)}, "no hole pixel has ground truth"),
        ({"edges": (10, 0)}, "increasing"),
        ({"edges": (5,)}, "increasing"),
        ({"pred": np.ones((8, 7), np.float32)}, "shape"),
        ({"pred": np.full((8, 8), np.nan, np.float32)}, "NaN"),
        ({"pred": np.full((8, 8), -1.0, np.float32)}, "negative"),
    ],
)
def test_depth_bins_reject_bad_input(change, match):
    args = {"pred": np.ones((8, 8), np.float32), "gt": np.full((8, 8), 3.0, np.float32),
                "hole": np.ones((8, 8), bool), "edges": (0, 10, np.inf)}
    args.update(change)
    with pytest.raises(ValueError, match=match):
        depth_binned_errors(args["pred"], args["gt"], args["hole"], edges=args["edges"])


@pytest.mark.parametrize("value", [256.0, 300.0, 1e6, 1e300])
def test_prediction_above_the_env_bound_is_refused_where_ground_truth_exists(value):
    # frame_metrics scored depth above 255.996 m that the environment refuses as an action.
    gt = np.full((8, 8), 10.0, np.float32)
    pred = np.full((8, 8), 10.0, np.float64)
    pred[3, 4] = value
    with pytest.raises(ValueError, match=r"prediction at pixels with ground truth has depth up to .* above the "
                                         r"bound 255.996 m, the most a KITTI 16-bit PNG can hold"):
        frame_metrics(pred, gt, np.ones((8, 8), bool))
    # As for NaN, only scored pixels count: above the bound where there is no ground truth is not scored.
    gt[3, 4] = 0.0
    assert float(frame_metrics(pred, gt, np.ones((8, 8), bool))["hole_rmse"]) == 0.0
    # The bound itself is a depth the environment accepts.
    pred[3, 4] = np.float32(65535 / 256)
    gt[3, 4] = 10.0
    assert np.isfinite(frame_metrics(pred, gt, np.ones((8, 8), bool))["hole_rmse"])
