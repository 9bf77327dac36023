"""Scorers: greater is better, usable as ``scoring=`` with and without y."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from sklearn.model_selection import GridSearchCV, GroupKFold, cross_validate

from estimators import all_rmse_scorer, hole_mae_scorer, hole_psnr_scorer, hole_rmse_scorer, make_inpaint_scorer
from estimators.classical import ConstantInpainter, ScanlineInpainter
from inpaintenv.data import ArrayDataset
from inpaintenv.masks import get_protocol
from inpaintenv.metrics import aggregate


@pytest.fixture(scope="module")
def gt() -> np.ndarray:
    rng = np.random.default_rng(2)
    rows = np.linspace(30.0, 4.0, 24, dtype=np.float32)[:, None]
    frames = np.stack([rows + 0.1 * k + np.zeros((1, 64), np.float32) for k in range(6)])
    frames[rng.random(frames.shape) < 0.3] = 0.0
    return frames.astype(np.float32)


def test_hole_rmse_scorer_equals_score(gt):
    est = ScanlineInpainter()
    assert hole_rmse_scorer(est, gt) == pytest.approx(est.score(gt))


@pytest.mark.parametrize(
    "scorer, key, sign",
    [(hole_rmse_scorer, "hole_rmse", -1), (hole_mae_scorer, "hole_mae", -1),
     (hole_psnr_scorer, "hole_psnr", 1), (all_rmse_scorer, "all_rmse", -1)],
)
def test_scorers_match_metrics_with_and_without_y(gt, scorer, key, sign):
    est = ConstantInpainter()
    expected = sign * aggregate(est.score_frames(gt))[key]
    assert scorer(est, gt) == pytest.approx(expected)
    hole = get_protocol("rect-v1").masks(gt.shape[1:], 0, range(len(gt)))
    x = gt.copy()
    x[hole] = np.nan
    assert scorer(est, x, gt) == pytest.approx(expected)


def test_greater_is_better(gt):
    good, bad = ScanlineInpainter(), ConstantInpainter()
    for scorer in (hole_rmse_scorer, hole_mae_scorer, hole_psnr_scorer):
        assert scorer(good, gt) > scorer(bad, gt)


def test_protocol_and_seed_change_the_holes(gt):
    est = ConstantInpainter()
    assert make_inpaint_scorer(seed=1)(est, gt) != make_inpaint_scorer(seed=0)(est, gt)


def test_scorers_in_grid_search_and_cross_validate(gt):
    data = ArrayDataset(gt, groups=["a", "a", "b", "b", "c", "c"])
    search = GridSearchCV(
        ScanlineInpainter(), {"inverse": [False, True]}, cv=GroupKFold(n_splits=3),
        scoring=hole_mae_scorer,
    )
    search.fit(data, groups=data.groups)
    assert search.best_params_["inverse"] in (False, True)
    assert np.isfinite(search.cv_results_["mean_test_score"]).all()
    res = cross_validate(
        ConstantInpainter(), data, groups=data.groups, cv=GroupKFold(n_splits=3),
        scoring={"rmse": hole_rmse_scorer, "psnr": hole_psnr_scorer, "all": all_rmse_scorer},
    )
    assert (res["test_rmse"] < 0).all() and (res["test_psnr"] > 0).all()


def test_scorer_pickles(gt):
    restored = pickle.loads(pickle.dumps(hole_psnr_scorer))
    assert restored(ConstantInpainter(), gt) == hole_psnr_scorer(ConstantInpainter(), gt)


@pytest.mark.parametrize(
    "kwargs, match",
    [({"metric": "rmse"}, "unknown metric"), ({"protocol": "nope"}, "unknown occlusion protocol"),
     ({"seed": -1}, "seed"), ({"seed": 1.5}, "seed")],
)
def test_make_scorer_validation(kwargs, match):
    with pytest.raises((ValueError, KeyError), match=match):
        make_inpaint_scorer(**kwargs)


def test_scorer_rejects_non_inpainter(gt):
    with pytest.raises(TypeError, match="BaseInpainter"):
        hole_rmse_scorer(object(), gt)


def test_scorer_without_ground_truth_in_holes_raises():
    gt = np.zeros((1, 16, 16), np.float32)
    gt[0, 0, 0] = 5.0
    with pytest.raises(ValueError, match="nothing to score"):
        hole_mae_scorer(ConstantInpainter(), gt)
