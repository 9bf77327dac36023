"""The shared estimator suite: every estimator in ``instances.ESTIMATORS`` must pass.

scikit-learn's own checks that make sense without 2-D tabular data are called
directly (``SKLEARN_CHECKS``); the rest of the file checks the depth-inpainting
contract on small frames.
"""

from __future__ import annotations

import pickle
import warnings

import numpy as np
import pytest

# tests/ has no __init__.py, so pytest puts this directory on sys.path.
from instances import ESTIMATORS
from sklearn.base import clone
from sklearn.exceptions import NotFittedError
from sklearn.utils import estimator_checks as skchecks

from inpaintenv.masks import get_protocol

H, W = 32, 96

# scikit-learn checks kept: they exercise the parameter protocol (get/set_params,
# clone, repr, tags) or fit on a 2-D array, which our fit reads as one frame. The
# others need tabular 2-D data, sample weights, sparse input or a classifier API.
SKLEARN_CHECKS = [
    skchecks.check_get_params_invariance,
    skchecks.check_set_params,
    skchecks.check_no_attributes_set_in_init,
    skchecks.check_parameters_default_constructible,
    skchecks.check_estimator_cloneable,
    skchecks.check_estimator_repr,
    skchecks.check_estimator_tags_renamed,
    skchecks.check_do_not_raise_errors_in_init_or_set_params,
    skchecks.check_mixin_order,
    skchecks.check_estimators_overwrite_params,
    skchecks.check_dont_overwrite_parameters,
    skchecks.check_estimators_fit_returns_self,
    skchecks.check_fit_check_is_fitted,
]

ids = [repr(e) for e in ESTIMATORS]
estimator_param = pytest.mark.parametrize("estimator", ESTIMATORS, ids=ids)


@pytest.fixture(scope="module")
def gt() -> np.ndarray:
    """Four 32×96 semi-dense ground-truth frames (depth grows towards the top)."""
    rng = np.random.default_rng(1)
    rows = np.linspace(30.0, 4.0, H, dtype=np.float32)[:, None]
    cols = np.sin(np.linspace(0, 3, W, dtype=np.float32))[None, :]
    frames = np.stack([rows + cols * (k + 1) for k in range(4)]).astype(np.float32)
    frames += rng.normal(0, 0.05, frames.shape).astype(np.float32)
    frames[rng.random(frames.shape) < 0.4] = 0.0
    return frames


@pytest.fixture(scope="module")
def x(gt) -> np.ndarray:
    """``gt`` with rect-v1 holes (NaN), the method input."""
    hole = get_protocol("rect-v1").masks((H, W), 0, range(len(gt)))
    out = gt.copy()
    out[hole] = np.nan
    return out


def fitted(estimator, gt):
    """A fitted clone (classical estimators need no fit, but fit must work)."""
    return clone(estimator).fit(gt)


@estimator_param
@pytest.mark.parametrize("check", SKLEARN_CHECKS, ids=lambda c: c.__name__)
def test_sklearn_check(estimator, check):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        check(type(estimator).__name__, clone(estimator))


@estimator_param
def test_clone_keeps_params(estimator):
    c = clone(estimator)
    assert c is not estimator
    assert c.get_params() == estimator.get_params()


@estimator_param
def test_fit_returns_self(estimator, gt):
    est = clone(estimator)
    assert est.fit(gt) is est
    assert est.fit(list(gt)) is est


@estimator_param
def test_unfitted(estimator, x):
    est = clone(estimator)
    if est._stateless:
        out = est.predict(x)
        assert out.shape == x.shape
    else:
        with pytest.raises(NotFittedError):
            est.predict(x)


@estimator_param
def test_output_contract(estimator, gt, x):
    est = fitted(estimator, gt)
    for inp in (x, x[0]):
        out = est.predict(inp)
        assert out.shape == inp.shape
        assert out.dtype == np.float32
        assert np.isfinite(out).all()
        assert (out >= 0).all()


@estimator_param
def test_keep_observed(estimator, gt, x):
    est = fitted(estimator, gt)
    observed = x > 0
    out = est.predict(x)
    np.testing.assert_array_equal(out[observed], x[observed])
    loose = fitted(clone(estimator).set_params(keep_observed=False), gt).predict(x)
    assert loose.shape == x.shape and np.isfinite(loose).all() and (loose >= 0).all()
    # Outside the observed pixels keep_observed changes nothing.
    np.testing.assert_array_equal(loose[~observed], out[~observed])


@estimator_param
def test_input_not_modified(estimator, gt, x):
    est = fitted(estimator, gt)
    inp = x.copy()
    est.predict(inp)
    np.testing.assert_array_equal(inp, x)


@estimator_param
def test_readonly_memmap_input(estimator, gt, x, tmp_path):
    est = fitted(estimator, gt)
    path = tmp_path / "x.dat"
    writer = np.memmap(path, dtype=np.float32, mode="w+", shape=x.shape)
    writer[:] = x
    writer.flush()
    del writer
    ro = np.memmap(path, dtype=np.float32, mode="r", shape=x.shape)
    np.testing.assert_array_equal(est.predict(ro), est.predict(x))


def _layouts(x: np.ndarray) -> dict[str, np.ndarray]:
    """``x``'s values in C order, Fortran order and as a strided view of a larger array."""
    big = np.zeros((x.shape[0], 2 * x.shape[1], 3 * x.shape[2]), x.dtype)
    strided = big[:, ::2, ::3]
    strided[:] = x
    return {"C": np.ascontiguousarray(x), "F": np.asfortranarray(x), "strided": strided,
            "transposed": np.ascontiguousarray(np.swapaxes(x, 1, 2)).swapaxes(1, 2)}


@estimator_param
def test_memory_layout_gives_identical_bits(estimator, gt, x):
    # Issue 24: Fortran-ordered input changed harmonic's output by up to 1.9e-6 m.
    est = fitted(estimator, gt)
    want = est.predict(x)
    for layout, given in _layouts(x).items():
        np.testing.assert_array_equal(est.predict(given), want, err_msg=layout)
        np.testing.assert_array_equal(est.predict(given[1]), want[1], err_msg=f"{layout}, one frame")


@estimator_param
def test_batch_equals_per_frame(estimator, gt, x):
    est = fitted(estimator, gt)
    batch = est.predict(x)
    for i in range(len(x)):
        np.testing.assert_array_equal(batch[i], est.predict(x[i]))


@estimator_param
def test_deterministic(estimator, gt, x):
    a = fitted(estimator, gt).predict(x)
    b = fitted(estimator, gt).predict(x)
    np.testing.assert_array_equal(a, b)


@estimator_param
def test_n_jobs_gives_identical_results(estimator, gt, x):
    if "n_jobs" not in estimator.get_params():
        pytest.skip("estimator has no n_jobs")
    one = fitted(clone(estimator).set_params(n_jobs=1), gt).predict(x)
    two = fitted(clone(estimator).set_params(n_jobs=2), gt).predict(x)
    np.testing.assert_array_equal(one, two)


@estimator_param
def test_pickle_round_trip(estimator, gt, x):
    est = fitted(estimator, gt)
    restored = pickle.loads(pickle.dumps(est))
    np.testing.assert_array_equal(restored.predict(x), est.predict(x))


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
