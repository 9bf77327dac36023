"""``check_inpainter``: scikit-learn's estimator checks that apply, run on depth maps.

``sklearn.utils.estimator_checks.check_estimator(est)`` runs one check on an inpainter
and skips the rest, because its tags say the input is not a 2-D table: a user sees a pass
although almost nothing was tested. :func:`check_inpainter` runs, on small depth frames
(or yours), the checks that carry over -- in the spirit of Gymnasium's ``check_env`` --
and says which ran and which were skipped and why::

    >>> from estimators.checks import check_inpainter
    >>> from estimators.classical import ScanlineInpainter
    >>> report = check_inpainter(ScanlineInpainter())
    >>> report["pickle_round_trip"]
    'passed'

Every check raises ``AssertionError`` naming itself when the estimator fails it. The
checks (:data:`CHECKS`): scikit-learn's parameter checks (``sklearn:*``), fit returning
``self``, fit idempotence, ``__dict__`` unchanged by ``predict``, pipeline consistency,
predictions independent of the batch they are in (subsets, order), of the memory layout
(C, Fortran, strided) and of the float dtype (float16/32/64), read-only memory-mapped
input, input never modified, the output contract, pickle and joblib memory-map round
trips, ``NotFittedError`` before ``fit``, and ``random_state`` taking an int, a
``RandomState``, a ``Generator`` or None. A learned estimator that is already fitted (a
pretrained release) is checked as it is: the checks that would refit it are skipped.
"""

from __future__ import annotations

import pickle
import tempfile
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import joblib
import numpy as np
from sklearn.base import clone
from sklearn.exceptions import NotFittedError
from sklearn.pipeline import make_pipeline
from sklearn.utils import estimator_checks as skchecks

from inpaintenv.conventions import check_depth
from inpaintenv.data.base import ArrayDataset
from inpaintenv.masks import get_protocol
from inpaintenv.exceptions import InpaintenvError, InvalidInputError, UnknownNameError

__all__ = ["CHECKS", "CheckData", "CheckSkipped", "check_inpainter", "make_check_data", "refits", "run_check",
           "training_frames"]

#: Shape of the frames :func:`make_check_data` draws when no ground truth is given.
CHECK_SHAPE = (4, 32, 96)


class CheckSkipped(InpaintenvError):
    """A check that does not apply to this estimator (the message says why); a signal to
    the check runner, like pytest's skip, not an error in the estimator."""


@dataclass
class CheckData:
    """Ground truth ``gt`` ``(N, H, W)``, the method input ``x`` (rect-v1 holes as NaN), and
    the fitted estimators of a run of checks (fitted once per estimator and reused)."""

    gt: np.ndarray
    x: np.ndarray
    _fitted: dict[int, Any] = field(default_factory=dict, repr=False)

    def fitted(self, estimator: Any) -> Any:
        """``estimator`` fitted on ``gt`` (a clone), or itself when :func:`refits` is False."""
        if not refits(estimator):
            return estimator
        key = id(estimator)
        if key not in self._fitted:
            self._fitted[key] = (estimator, _seeded(clone(estimator)).fit(training_frames(estimator, self.gt)))
        return self._fitted[key][1]


def make_check_data(X: Any = None) -> CheckData:
    """The frames the checks run on: ``X`` (ground truth, ``(N, H, W)`` metres, N >= 2),
    else :data:`CHECK_SHAPE` semi-dense synthetic frames (depth growing towards the top)."""
    if X is None:
        n, h, w = CHECK_SHAPE
        rng = np.random.default_rng(1)
        rows = np.linspace(30.0, 4.0, h, dtype=np.float32)[:, None]
        cols = np.sin(np.linspace(0, 3, w, dtype=np.float32))[None, :]
        gt = np.stack([rows + cols * (k + 1) for k in range(n)]).astype(np.float32)
        gt += rng.normal(0, 0.05, gt.shape).astype(np.float32)
        gt[rng.random(gt.shape) < 0.4] = 0.0
    else:
        gt = check_depth(np.asarray(X), name="X", ndim=(3,))
        if len(gt) < 2:
            raise InvalidInputError(f"X must hold at least 2 frames for the batch checks, got {len(gt)}")
    hole = get_protocol("rect-v1").masks(gt.shape[1:], 0, range(len(gt)))
    return CheckData(gt=gt, x=np.where(hole, np.float32(np.nan), gt).astype(np.float32))


def training_frames(estimator: Any, gt: np.ndarray) -> Any:
    """What the checks fit ``estimator`` on: ``gt``, as frames of one drive each where the
    estimator calibrates on whole drives (``_needs_drive_ids``, e.g. an interval wrapper),
    with a scan of every other row of ``gt`` as each frame's input where it learns from
    scans only (``_needs_scans``; such a dataset has no calibration to find laser rings by)."""
    if getattr(estimator, "_needs_drive_ids", False):
        return ArrayDataset(gt, groups=[f"check-drive-{i}" for i in range(len(gt))])
    if getattr(estimator, "_needs_scans", False):
        scans = np.zeros_like(gt)
        scans[:, ::2] = gt[:, ::2]
        return ArrayDataset(gt, inputs=scans)
    return gt


def _needs_plain_fit(estimator: Any, what: str) -> None:
    if getattr(estimator, "_needs_drive_ids", False):
        raise CheckSkipped(f"the estimator calibrates on whole drives: {what} passes no drive ids")
    if getattr(estimator, "_needs_scans", False):
        raise CheckSkipped(f"the estimator learns from LiDAR scans: {what} passes depth maps")


def _needs_depth_frames(estimator: Any) -> None:
    if getattr(estimator, "_learns_far_pixels", False):
        raise CheckSkipped("the estimator learns only pixels far from every measurement: scikit-learn's small "
                           "tables have none")


def refits(estimator: Any) -> bool:
    """Whether the checks may (re)fit ``estimator``: not for a learned one already fitted."""
    stateless = getattr(estimator, "_stateless", False)
    fitted = bool(getattr(estimator, "__sklearn_is_fitted__", lambda: False)())
    return stateless or not fitted


def _seeded(estimator: Any) -> Any:
    """``estimator`` with ``random_state=0`` if it has one left at None (as scikit-learn's checks do)."""
    if "random_state" in estimator.get_params() and estimator.get_params()["random_state"] is None:
        estimator.set_params(random_state=0)
    return estimator


def _needs_refit(estimator: Any) -> None:
    if not refits(estimator):
        raise CheckSkipped("the estimator is already fitted (pretrained): refitting would retrain it")


def _same(a: np.ndarray, b: np.ndarray, what: str) -> None:
    if not (a.shape == b.shape and np.array_equal(a, b, equal_nan=True)):
        diff = np.nanmax(np.abs(a.astype(np.float64) - b)) if a.shape == b.shape else f"shapes {a.shape} {b.shape}"
        raise AssertionError(f"{what}: predictions differ (max difference {diff})")


# ---------------------------------------------------------------------------------------
# The checks: each takes (estimator, data) and raises AssertionError or CheckSkipped.
# ---------------------------------------------------------------------------------------
def check_fit_returns_self(est: Any, data: CheckData) -> None:
    _needs_refit(est)
    e = _seeded(clone(est))
    assert e.fit(training_frames(e, data.gt)) is e, "fit(X) must return self"
    if not (getattr(e, "_needs_drive_ids", False) or getattr(e, "_needs_scans", False)):
        assert e.fit(list(data.gt)) is e, "fit on a list of frames must return self"


def check_fit_idempotent(est: Any, data: CheckData) -> None:
    _needs_refit(est)
    e = _seeded(clone(est))
    frames = training_frames(e, data.gt)
    first = e.fit(frames).predict(data.x)
    _same(e.fit(frames).predict(data.x), first, "fitting twice")
    _same(_seeded(clone(est)).fit(frames).predict(data.x), first, "a clone fitted alike")


def check_dict_unchanged_by_predict(est: Any, data: CheckData) -> None:
    e = data.fitted(est)
    before = joblib.hash(e.__dict__)
    e.predict(data.x)
    e.predict(data.x[0])
    assert joblib.hash(e.__dict__) == before, "predict changed the estimator's __dict__"


def check_pipeline_consistency(est: Any, data: CheckData) -> None:
    _needs_refit(est)
    _needs_plain_fit(est, "a Pipeline")
    pipe = make_pipeline(_seeded(clone(est))).fit(data.gt)
    _same(pipe.predict(data.x), data.fitted(est).predict(data.x), "in a Pipeline")
    assert np.isclose(pipe.score(data.x, data.gt), data.fitted(est).score(data.x, data.gt)), "Pipeline.score differs"


def check_batch_subset_invariance(est: Any, data: CheckData) -> None:
    e = data.fitted(est)
    full = e.predict(data.x)
    _same(e.predict(data.x[1:]), full[1:], "a subset of the batch")
    for k in range(len(data.x)):
        _same(e.predict(data.x[k]), full[k], f"frame {k} alone")


def check_batch_order_invariance(est: Any, data: CheckData) -> None:
    e = data.fitted(est)
    order = np.random.default_rng(0).permutation(len(data.x))
    _same(e.predict(data.x[order]), e.predict(data.x)[order], "the batch in another order")


def check_memory_layout(est: Any, data: CheckData) -> None:
    e = data.fitted(est)
    want = e.predict(data.x)
    big = np.zeros((len(data.x), 2 * data.x.shape[1], 3 * data.x.shape[2]), np.float32)
    strided = big[:, ::2, ::3]
    strided[:] = data.x
    layouts = {"Fortran-ordered": np.asfortranarray(data.x), "strided": strided,
               "transposed copy": np.ascontiguousarray(np.swapaxes(data.x, 1, 2)).swapaxes(1, 2)}
    for name, given in layouts.items():
        _same(e.predict(given), want, f"{name} input")


def check_float_dtypes(est: Any, data: CheckData) -> None:
    e = data.fitted(est)
    _same(e.predict(data.x.astype(np.float64)), e.predict(data.x), "float64 input")
    x16 = data.x.astype(np.float16)
    out = e.predict(x16)
    assert out.dtype == np.float32, f"float16 input gave {out.dtype}, not float32"
    _same(out, e.predict(x16.astype(np.float32)), "float16 input")


def check_readonly_memmap_input(est: Any, data: CheckData) -> None:
    e = data.fitted(est)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "x.dat"
        writer = np.memmap(path, dtype=np.float32, mode="w+", shape=data.x.shape)
        writer[:] = data.x
        writer.flush()
        del writer
        _same(e.predict(np.memmap(path, dtype=np.float32, mode="r", shape=data.x.shape)), e.predict(data.x),
              "read-only memory-mapped input")


def check_input_not_modified(est: Any, data: CheckData) -> None:
    given = data.x.copy()
    data.fitted(est).predict(given)
    assert np.array_equal(given, data.x, equal_nan=True), "predict modified its input"


def check_output_contract(est: Any, data: CheckData) -> None:
    e = data.fitted(est)
    for given in (data.x, data.x[0]):
        out = e.predict(given)
        assert out.shape == given.shape and out.dtype == np.float32, f"got {out.dtype} {out.shape} for {given.shape}"
        assert np.isfinite(out).all() and (out >= 0).all(), "output must be finite and non-negative everywhere"
        if e.get_params().get("keep_observed", True):
            observed = given > 0
            assert np.array_equal(out[observed], given[observed]), "keep_observed: measured pixels changed"


def check_pickle_round_trip(est: Any, data: CheckData) -> None:
    e = data.fitted(est)
    _same(pickle.loads(pickle.dumps(e)).predict(data.x), e.predict(data.x), "after a pickle round trip")


def check_joblib_mmap_round_trip(est: Any, data: CheckData) -> None:
    e = data.fitted(est)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "est.joblib"
        joblib.dump(e, path)
        restored = joblib.load(path, mmap_mode="r")  # NumPy attributes come back read-only
        _same(restored.predict(data.x), e.predict(data.x), "after joblib.dump / load(mmap_mode='r')")


def check_unfitted(est: Any, data: CheckData) -> None:
    if not refits(est):
        raise CheckSkipped("the estimator comes fitted (pretrained): it has no unfitted state")
    e = clone(est)
    if getattr(e, "_stateless", False):
        assert e.predict(data.x).shape == data.x.shape, "a stateless estimator predicts without fit"
        return
    try:
        e.predict(data.x)
    except NotFittedError:
        return
    raise AssertionError("predict before fit must raise NotFittedError")


def check_random_state_types(est: Any, data: CheckData) -> None:
    if "random_state" not in est.get_params():
        raise CheckSkipped("the estimator has no random_state")
    _needs_refit(est)
    for value in (0, np.random.RandomState(0), np.random.default_rng(0), None):
        out = clone(est).set_params(random_state=value).fit(training_frames(est, data.gt)).predict(data.x)
        assert out.shape == data.x.shape and np.isfinite(out).all(), f"random_state={value!r} gave a bad output"
    for bad in (-1, 1.5, "0"):
        try:
            clone(est).set_params(random_state=bad).fit(training_frames(est, data.gt))
        except (TypeError, ValueError):
            continue
        raise AssertionError(f"random_state={bad!r} must be refused")


def _sklearn(check: Callable[[str, Any], None], fits: bool) -> Callable[[Any, CheckData], None]:
    def run(est: Any, data: CheckData) -> None:
        if fits:
            _needs_refit(est)
            _needs_plain_fit(est, "scikit-learn's check")
            _needs_depth_frames(est)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            check(type(est).__name__, clone(est))

    run.__name__ = run.__qualname__ = check.__name__
    return run


#: scikit-learn's checks that apply to depth maps: the parameter protocol (get/set_params,
#: clone, repr, tags) and fits on 2-D arrays, which ``fit`` reads as one frame. The others
#: need tabular samples and features, sample weights, sparse input or a classifier API.
SKLEARN_CHECKS = (
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
)
#: Those of them that fit the estimator (skipped for a pretrained one).
_SKLEARN_FITTING = (
    skchecks.check_estimators_overwrite_params, skchecks.check_dont_overwrite_parameters,
    skchecks.check_estimators_fit_returns_self, skchecks.check_fit_check_is_fitted,
)

#: Every check by name, in the order :func:`check_inpainter` runs them.
CHECKS: dict[str, Callable[[Any, CheckData], None]] = {
    **{f"sklearn:{c.__name__}": _sklearn(c, c in _SKLEARN_FITTING) for c in SKLEARN_CHECKS},
    "fit_returns_self": check_fit_returns_self,
    "fit_idempotent": check_fit_idempotent,
    "unfitted": check_unfitted,
    "output_contract": check_output_contract,
    "dict_unchanged_by_predict": check_dict_unchanged_by_predict,
    "pipeline_consistency": check_pipeline_consistency,
    "batch_subset_invariance": check_batch_subset_invariance,
    "batch_order_invariance": check_batch_order_invariance,
    "memory_layout": check_memory_layout,
    "float_dtypes": check_float_dtypes,
    "readonly_memmap_input": check_readonly_memmap_input,
    "input_not_modified": check_input_not_modified,
    "pickle_round_trip": check_pickle_round_trip,
    "joblib_mmap_round_trip": check_joblib_mmap_round_trip,
    "random_state_types": check_random_state_types,
}


def run_check(estimator: Any, name: str, data: CheckData) -> None:
    """Run the check ``name`` of :data:`CHECKS`; its ``AssertionError`` names it.

    Raises
    ------
    CheckSkipped
        If the check does not apply to ``estimator``.
    AssertionError
        If ``estimator`` fails it.
    KeyError
        For an unknown name.
    """
    if name not in CHECKS:
        raise UnknownNameError(f"unknown check {name!r}; known: {', '.join(CHECKS)}")
    try:
        CHECKS[name](estimator, data)
    except AssertionError as exc:
        raise AssertionError(f"{type(estimator).__name__} fails check {name!r}: {exc}") from exc


def check_inpainter(estimator: Any, X: Any = None) -> dict[str, str]:
    """Run every check of :data:`CHECKS` on ``estimator``; fail on the first that fails.

    Parameters
    ----------
    estimator : inpainter
        A scikit-learn style inpainter (``fit`` on ground truth, ``predict`` on NaN-holed
        depth). A learned estimator that is already fitted (e.g.
        ``estimators.learned.load_release()``) is checked as it is, without refitting.
    X : array-like, optional
        Ground truth ``(N, H, W)`` in metres (N >= 2) to check on, e.g. frames of the
        size a pretrained model expects; by default small synthetic frames.

    Returns
    -------
    dict of str to str
        Check name -> ``"passed"`` or ``"skipped: <reason>"``, in the order run.

    Raises
    ------
    AssertionError
        Naming the estimator and the first check it fails.
    """
    data = make_check_data(X)
    report: dict[str, str] = {}
    for name in CHECKS:
        try:
            run_check(estimator, name, data)
        except CheckSkipped as why:
            report[name] = f"skipped: {why}"
        else:
            report[name] = "passed"
    return report
