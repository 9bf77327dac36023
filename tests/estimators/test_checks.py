"""``estimators.checks.check_inpainter``: what it reports, and that it catches broken estimators."""

from __future__ import annotations

import numpy as np
import pytest

from estimators.checks import CHECKS, check_inpainter, make_check_data
from estimators.classical import ConstantInpainter, ScanlineInpainter


def test_reports_every_check_and_why_one_was_skipped():
    report = check_inpainter(ScanlineInpainter())
    assert list(report) == list(CHECKS)
    assert report["random_state_types"] == "skipped: the estimator has no random_state"
    assert all(v == "passed" for k, v in report.items() if k != "random_state_types")


class LayoutDependent(ConstantInpainter):
    """Adds a millimetre for Fortran-ordered input."""

    def predict(self, X):
        return super().predict(X) + np.float32(0.001 if np.isfortran(X) else 0.0)


class CountsCalls(ConstantInpainter):
    """Writes to itself in predict."""

    def predict(self, X):
        self.calls_ = getattr(self, "calls_", 0) + 1
        return super().predict(X)


class OrderDependent(ConstantInpainter):
    """Fills every frame with the first frame's median: the batch changes the result."""

    def predict(self, X):
        out = super().predict(X)
        if out.ndim == 3:
            out[1:] = np.where(np.isnan(np.asarray(X)[1:]), out[0].max(), out[1:])
        return out


@pytest.mark.parametrize(
    "estimator, check",
    [(LayoutDependent(), "memory_layout"), (CountsCalls(), "dict_unchanged_by_predict"),
     (OrderDependent(), "batch_subset_invariance")],
)
def test_a_broken_estimator_fails_the_check_that_names_it(estimator, check):
    with pytest.raises(AssertionError, match=f"{type(estimator).__name__} fails check '{check}'"):
        check_inpainter(estimator)


def test_custom_frames_and_their_validation():
    rng = np.random.default_rng(0)
    frames = np.where(rng.random((3, 24, 40)) < 0.5, rng.uniform(2, 50, (3, 24, 40)), 0.0)
    assert check_inpainter(ConstantInpainter(), frames)["memory_layout"] == "passed"
    with pytest.raises(ValueError, match="at least 2 frames"):
        make_check_data(frames[:1])


def test_pretrained_release_is_checked_without_refitting():
    pytest.importorskip("torch")
    from estimators.learned import load_release

    est = load_release().named_estimators_["blend"]  # the default release's BlendInpainter
    before = {k: v for k, v in est.get_params().items()}
    report = check_inpainter(est)
    skipped = {k for k, v in report.items() if v.startswith("skipped: the estimator is already fitted")}
    assert {"fit_idempotent", "pipeline_consistency", "random_state_types", "sklearn:check_fit_check_is_fitted"} <= skipped
    assert {"memory_layout", "float_dtypes", "pickle_round_trip", "joblib_mmap_round_trip",
            "batch_order_invariance", "dict_unchanged_by_predict"} <= {k for k, v in report.items() if v == "passed"}
    assert est.get_params() == before
