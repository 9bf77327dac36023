"""The shared estimator suite: every public estimator class (found by ``instances``) and the
shipped default must pass.

``estimators.checks`` (the public ``check_inpainter``) holds scikit-learn's applicable
checks and the depth-map contract (fit idempotence, batch and layout invariance, pickle
and joblib round trips, ...): every one of its checks runs here on every estimator, one
test each. The rest of the file checks what is specific to inpainting on small frames.
"""

from __future__ import annotations

import numpy as np
import pytest

# tests/ has no __init__.py, so pytest puts this directory on sys.path.
from instances import CONFIGS, DEFAULT_METHODS, ESTIMATORS, public_classes
from param_values import param_values
from sklearn.base import clone

from estimators.checks import CHECKS, CheckSkipped, make_check_data, refits, run_check, training_frames

H, W = 32, 96

ids = [repr(e) for e in ESTIMATORS]
estimator_param = pytest.mark.parametrize("estimator", ESTIMATORS, ids=ids)


@pytest.fixture(scope="module")
def check_data():
    """Four 32×96 semi-dense frames and their rect-v1 inputs; fitted estimators cached."""
    return make_check_data()


@pytest.fixture(scope="module")
def gt(check_data) -> np.ndarray:
    return check_data.gt


@pytest.fixture(scope="module")
def x(check_data) -> np.ndarray:
    """``gt`` with rect-v1 holes (NaN), the method input."""
    return check_data.x


def fitted(estimator, gt):
    """A fitted clone (classical estimators need no fit, but fit must work); a model that
    comes fitted (a pretrained release, the default's router) as it is."""
    if not refits(estimator):
        return estimator
    return clone(estimator).fit(training_frames(estimator, gt))


def test_every_public_class_and_the_default_are_checked():
    classes = public_classes()
    assert set(CONFIGS) <= set(classes), f"configurations of no public class: {sorted(set(CONFIGS) - set(classes))}"
    checked = {type(e).__name__ for e in ESTIMATORS}
    assert set(classes) <= checked, f"public estimators the shared suite misses: {sorted(set(classes) - checked)}"
    assert len(ESTIMATORS) == sum(len(CONFIGS.get(name, [dict])) for name in classes) + len(DEFAULT_METHODS)


@estimator_param
@pytest.mark.parametrize("check", list(CHECKS))
def test_inpainter_check(estimator, check, check_data):
    try:
        run_check(estimator, check, check_data)
    except CheckSkipped as why:
        pytest.skip(str(why))


@estimator_param
def test_clone_keeps_params(estimator):
    c = clone(estimator)
    assert c is not estimator
    assert param_values(c.get_params()) == param_values(estimator.get_params())


@estimator_param
def test_keep_observed(estimator, gt, x):
    est = fitted(estimator, gt)
    observed = x > 0
    out = est.predict(x)
    np.testing.assert_array_equal(out[observed], x[observed])
    if "keep_observed" not in est.get_params(deep=False):
        return  # a wrapper or router keeps what its fills keep: checked above
    loose = fitted(clone(estimator).set_params(keep_observed=False), gt).predict(x)
    assert loose.shape == x.shape and np.isfinite(loose).all() and (loose >= 0).all()
    # Outside the observed pixels keep_observed changes nothing.
    np.testing.assert_array_equal(loose[~observed], out[~observed])


@estimator_param
def test_n_jobs_gives_identical_results(estimator, gt, x):
    if "n_jobs" not in estimator.get_params():
        pytest.skip("estimator has no n_jobs")
    one = fitted(clone(estimator).set_params(n_jobs=1), gt).predict(x)
    two = fitted(clone(estimator).set_params(n_jobs=2), gt).predict(x)
    np.testing.assert_array_equal(one, two)


@estimator_param
def test_frame_without_measurements(estimator, gt):
    est = fitted(estimator, gt)
    empty = np.zeros((H, W), np.float32)
    empty[5:15, 10:40] = np.nan
    out = est.predict(empty)
    assert np.isfinite(out).all() and (out >= 0).all()


def _sparse_eye():
    from scipy import sparse

    return sparse.csr_matrix(np.eye(8))


@estimator_param
@pytest.mark.parametrize(
    "bad, error, match",
    [
        (np.full(5, np.nan, np.float32), ValueError, "2-D or 3-D"),
        (np.full((1, 1, 4, 4), np.nan, np.float32), ValueError, "2-D or 3-D"),
        (np.zeros((0, 4), np.float32), ValueError, "empty"),
        (np.zeros((4, 4), bool), TypeError, "boolean"),
        (np.full((4, 4), None, dtype=object), TypeError, "dtype object"),
        (np.full((4, 4), 1 + 1j), TypeError, "complex"),
        (np.array([[np.nan, np.inf], [1.0, 2.0]]), ValueError, "infinite"),
        (np.array([[np.nan, -1.0], [1.0, 2.0]]), ValueError, "negative"),
        (np.ones((4, 4), np.float32), ValueError, "no NaN"),
        (np.ones((4, 4), np.int64), TypeError, "integer dtype int64"),
        (np.full((8, 8), 7, np.uint8), TypeError, "integer dtype uint8"),
        (np.ma.masked_invalid(np.full((8, 8), np.nan)), TypeError, "masked array"),
        # 1e39 overflows float32: the message says what is really wrong, not "infinite".
        (np.where(np.eye(8, dtype=bool), np.nan, 1e39), ValueError, r"depth up to 1e\+39 m, above 255.996 m"),
        (np.where(np.eye(8, dtype=bool), np.nan, 1e-30), ValueError, "below 0.001 m"),
        (np.where(np.eye(8, dtype=bool), np.nan, 1e-42).astype(np.float32), ValueError, "below 0.001 m"),
        (_sparse_eye(), TypeError, r"scipy.sparse csr_matrix; depth maps are dense arrays: pass X.toarray\(\)"),
    ],
    ids=["1d", "4d", "empty", "bool", "object", "complex", "inf", "negative", "no-nan", "int64", "uint8", "masked",
         "float32-overflow", "tiny", "subnormal", "sparse"],
)
def test_predict_validation(estimator, gt, bad, error, match):
    est = fitted(estimator, gt)
    with pytest.raises(error, match=match):
        est.predict(bad)


@estimator_param
def test_fit_validation(estimator):
    with pytest.raises(ValueError, match="NaN"):
        clone(estimator).fit(np.full((2, H, W), np.nan, np.float32))
    with pytest.raises(ValueError):
        clone(estimator).fit(np.zeros((0, H, W), np.float32))


@estimator_param
def test_score(estimator, gt, x):
    est = fitted(estimator, gt)
    without_y = est.score(gt)
    with_y = est.score(x, gt)
    # Without y the estimator corrupts gt with rect-v1 / seed 0 -- the same holes as x.
    assert without_y == pytest.approx(with_y)
    assert np.isfinite(without_y) and without_y <= 0


def test_a_subclass_without_predict_batch_is_told_what_to_implement():
    from estimators.base import BaseInpainter

    class Half(BaseInpainter):
        def _fit(self, dataset):
            pass

    x = np.full((8, 8), np.nan, np.float32)
    x[0, 0] = 1.0
    with pytest.raises(NotImplementedError, match="Half must implement _predict_batch"):
        Half().fit(np.ones((2, 8, 8), np.float32)).predict(x)
