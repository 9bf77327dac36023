"""frame_metrics on random inputs: a documented error, NaN-skip, or the reference value.

The reference is the slow obvious pixel loop; every finite number frame_metrics returns
must agree with it, so a fast path can never drift into a silently wrong metric.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from fuzz_settings import fast
from hypothesis import given
from hypothesis import strategies as st

from inpaintenv.conventions import MIN_FRAME_SIDE
from inpaintenv.metrics import METRIC_NAMES, REGIONS, aggregate, frame_metrics

SPECIALS = (np.nan, np.inf, -np.inf, -1.0, 0.0)


def reference(pred: np.ndarray, gt: np.ndarray, hole: np.ndarray, max_depth: float = 80.0) -> dict:
    """Per-frame metrics of one (H, W) frame by a Python loop over pixels."""
    out: dict[str, float] = {}
    for region in REGIONS:
        se = ae = ise = iae = 0.0
        n = 0
        for (i, j), g in np.ndenumerate(gt):
            if g <= 0 or (region == "hole" and not hole[i, j]):
                continue
            p, g = float(pred[i, j]), float(g)
            n += 1
            se += (p - g) ** 2
            ae += abs(p - g)
            ie = 1000.0 / max(p, 0.1) - 1000.0 / g
            ise += ie * ie
            iae += abs(ie)
        out[f"{region}_count"] = n
        if n == 0:
            out.update({f"{region}_{m}": math.nan for m in METRIC_NAMES})
            continue
        out[f"{region}_rmse"] = math.sqrt(se / n)
        out[f"{region}_mae"] = ae / n
        out[f"{region}_irmse"] = math.sqrt(ise / n)
        out[f"{region}_imae"] = iae / n
        out[f"{region}_psnr"] = 20 * math.log10(max_depth / max(math.sqrt(se / n), 1e-6))
    return out


@st.composite
def cases(draw):
    """(pred, gt, hole) with random shape, density, dtype and injected special values."""
    n = draw(st.integers(1, 3))
    h, w = draw(st.integers(1, 11)), draw(st.integers(1, 11))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    shape = (n, h, w)
    gt = rng.uniform(0.5, 90.0, shape).astype(np.float32)
    gt[rng.random(shape) < draw(st.sampled_from([0.0, 0.5, 1.0]))] = 0.0  # 1.0: all-zero gt
    pred = np.abs(gt + rng.normal(0, 3, shape)).astype(draw(st.sampled_from([np.float32, np.float64, np.float16])))
    hole = rng.random(shape) < draw(st.sampled_from([0.0, 0.3, 1.0]))  # 0.0: empty holes
    for arr in (pred, gt):
        if draw(st.booleans()):
            arr.reshape(-1)[rng.integers(arr.size)] = draw(st.sampled_from(SPECIALS))
    if draw(st.booleans()):
        return pred[0], gt[0], hole[0]
    return pred, gt, hole


@fast(60)
@given(case=cases())
def test_error_nan_skip_or_the_reference(case):
    pred, gt, hole = case
    bad_gt = not np.isfinite(gt).all() or (gt < 0).any()
    # (N, H, 1/3/4) reads as a channel axis, and a batch's frames are at least MIN_FRAME_SIDE: refused
    bad_gt |= gt.ndim == 3 and (gt.shape[-1] in (1, 3, 4) or min(gt.shape[1:]) < MIN_FRAME_SIDE)
    scored = pred[gt > 0]
    bad_pred = not np.isfinite(scored).all() or (scored < 0).any()
    if bad_gt or bad_pred:
        with pytest.raises(ValueError):
            frame_metrics(pred, gt, hole)
        return
    got = frame_metrics(pred, gt, hole)
    batch = (pred, gt, hole) if gt.ndim == 3 else (pred[None], gt[None], hole[None])
    for k, frame in enumerate(zip(*batch)):
        want = reference(*frame)
        for key, value in want.items():
            v = np.atleast_1d(got[key])[k]
            if math.isnan(value):
                assert math.isnan(v), key  # no ground truth in the region: NaN, skipped
            else:
                assert v == pytest.approx(value, rel=1e-9, abs=1e-9), key
    table = aggregate(got)
    assert table["n_skipped_hole"] == int((np.atleast_1d(got["hole_count"]) == 0).sum())


@fast(20)
@given(
    shapes=st.tuples(
        st.tuples(st.integers(1, 4), st.integers(1, 4)), st.tuples(st.integers(1, 4), st.integers(1, 4))
    ).filter(lambda s: s[0] != s[1]),
    which=st.sampled_from(["pred", "hole"]),
)
def test_shape_mismatch_is_a_value_error(shapes, which):
    a, b = (np.ones(s, dtype=np.float32) for s in shapes)
    args = {"pred": (b, a, a > 0), "hole": (a, a, b > 0)}[which]
    with pytest.raises(ValueError, match="shape"):
        frame_metrics(*args)


@pytest.mark.parametrize(
    "pred, hole, error",
    [
        (np.full((2, 2), "x"), np.ones((2, 2), bool), TypeError),
        (np.ones((2, 2), complex), np.ones((2, 2), bool), TypeError),
        (np.ones((2, 2)), np.full((2, 2), 2), ValueError),
        (np.ones((2, 2)), np.full((2, 2), "a"), TypeError),
    ],
)
def test_bad_dtypes_are_documented_errors(pred, hole, error):
    with pytest.raises(error):
        frame_metrics(pred, np.ones((2, 2), np.float32), hole)
