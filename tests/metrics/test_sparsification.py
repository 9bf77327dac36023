"""AUSE, AURG and AUCE against a NumPy recomputation written here from their definitions, in both conventions."""

from __future__ import annotations

import numpy as np
import pytest

from inpaintenv.metrics import CALIBRATION_LEVELS, REMOVED, auce, calibration, sparsification

N_FRAMES, N_PIXELS = 3, 100  # 100 scored pixels a frame: every removed fraction keeps a whole number


@pytest.fixture
def frames():
    """Three 12x20 frames with 100 scored pixels each (the rest: no truth or outside the task)."""
    rng = np.random.default_rng(1)
    gt = rng.uniform(2.0, 60.0, (N_FRAMES, 12, 20))
    scored = np.zeros(gt.shape, bool)
    for k in range(N_FRAMES):
        scored[k].reshape(-1)[rng.choice(240, N_PIXELS, replace=False)] = True
    gt[~scored & (rng.random(gt.shape) < 0.5)] = 0.0  # no truth outside the task: never read
    pred = gt + rng.normal(0.0, 1.0 + 0.05 * gt)
    pred = np.maximum(pred, 0.1)
    return pred, gt, scored


def _curve(err: np.ndarray, unc: np.ndarray, metric: str) -> np.ndarray:
    """The definition: drop the most uncertain fraction r, the error of the rest, for each r."""
    order = np.argsort(-unc)  # most uncertain first (no ties: continuous random uncertainties)
    out = []
    for r in REMOVED:
        kept = err[order][int(round(r * err.size)):]
        out.append(np.sqrt(np.mean(kept**2)) if metric == "rmse" else np.mean(kept))
    return np.array(out)


def _reference(pred, gt, unc, scored, convention, metric):
    removed = np.array(REMOVED)
    groups = [slice(None)] if convention == "pooled" else range(N_FRAMES)
    ause, aurg = [], []
    for g in groups:
        valid = scored[g] & (gt[g] > 0)
        err, u = np.abs(pred[g] - gt[g])[valid], unc[g][valid]
        curve, oracle = _curve(err, u, metric), _curve(err, err, metric)
        random = np.full(removed.size, curve[0])
        if convention == "pooled":
            curve, oracle, random = curve / curve[0], oracle / curve[0], random / curve[0]
        area = lambda y: float(np.sum((y[1:] + y[:-1]) / 2 * np.diff(removed)))
        ause.append(area(curve - oracle))
        aurg.append(area(random - curve))
    return (ause[0], aurg[0]) if convention == "pooled" else (np.array(ause), np.array(aurg))


@pytest.mark.parametrize("convention", ["pooled", "per_image"])
@pytest.mark.parametrize("metric", ["rmse", "mae"])
@pytest.mark.parametrize("ranking", ["random", "informative", "oracle", "reversed"])
def test_ause_and_aurg_equal_their_definition(frames, convention, metric, ranking):
    pred, gt, scored = frames
    err = np.abs(pred - gt)
    rng = np.random.default_rng(2)
    unc = {"random": rng.random(gt.shape), "informative": err + rng.uniform(0, 2.0, gt.shape),
           "oracle": err, "reversed": 1000.0 - err}[ranking]
    got = sparsification(pred, gt, unc, scored, convention, metric)
    ause, aurg = _reference(pred, gt, unc, scored, convention, metric)
    np.testing.assert_allclose(got["ause"], ause, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(got["aurg"], aurg, rtol=1e-9, atol=1e-12)
    assert got["convention"] == convention
    if ranking == "oracle":
        np.testing.assert_allclose(got["ause"], 0.0, atol=1e-12)
    if ranking == "reversed":  # the largest AUSE: no ranking does worse, the random one does better
        worse_than = sparsification(pred, gt, rng.random(gt.shape), scored, convention, metric)["ause"]
        assert np.all(got["ause"] > worse_than)
        np.testing.assert_allclose(got["ause"], np.trapezoid(got["curve"] - got["oracle"], REMOVED, axis=-1))


def test_a_constant_uncertainty_is_random_removal(frames):
    pred, gt, scored = frames
    got = sparsification(pred, gt, np.ones(gt.shape), scored, "pooled")
    np.testing.assert_allclose(got["curve"], 1.0)
    np.testing.assert_allclose(got["aurg"], 0.0, atol=1e-12)


def test_per_image_is_computed_with_one_sort_for_every_frame(frames):
    """Each frame's figure is the one it has alone (the batch is vectorised, not mixed)."""
    pred, gt, scored = frames
    unc = np.random.default_rng(3).random(gt.shape)
    together = sparsification(pred, gt, unc, scored, "per_image")
    for k in range(N_FRAMES):
        alone = sparsification(pred[k], gt[k], unc[k], scored[k], "per_image")
        np.testing.assert_allclose(together["ause"][k], alone["ause"][0], rtol=1e-12)


@pytest.mark.parametrize("convention", ["pooled", "per_image"])
def test_auce_equals_its_definition(frames, convention):
    pred, gt, scored = frames
    from statistics import NormalDist

    sigma = 0.5 + 0.04 * gt  # an interval a bit too narrow: coverage below nominal
    intervals = {}
    for c in CALIBRATION_LEVELS:
        z = NormalDist().inv_cdf((1 + c) / 2)
        intervals[c] = (pred - z * sigma, pred + z * sigma)
    got = calibration(gt, scored, intervals, convention)
    levels = np.array(CALIBRATION_LEVELS)
    groups = [slice(None)] if convention == "pooled" else range(N_FRAMES)
    ref = []
    for g in groups:
        valid = scored[g] & (gt[g] > 0)
        cov = np.array([np.mean((intervals[c][0][g][valid] <= gt[g][valid]) & (gt[g][valid] <= intervals[c][1][g][valid]))
                        for c in CALIBRATION_LEVELS])
        gap = np.abs(cov - levels)
        ref.append(float(np.sum((gap[1:] + gap[:-1]) / 2 * np.diff(levels))))
    np.testing.assert_allclose(got["auce"], ref[0] if convention == "pooled" else ref, rtol=1e-12)
    # A calibrated diagram has AUCE 0; the worst (nothing covered) the area under the diagonal.
    assert auce(levels) == 0.0
    assert auce(np.zeros(levels.size)) == pytest.approx(np.trapezoid(levels, levels))
