"""What learned methods return in the pixels they fill.

Every hole pixel of a frame with a measurement is a positive depth, at least
``MIN_HOLE_DEPTH`` (a net's raw output at or below 0 m used to be clipped to 0 m, which the
benchmark refuses as unfilled); a frame without a measured pixel has nothing to fill from and
its holes are 0 m, as every classical method returns them.
"""

from __future__ import annotations

import numpy as np
import pytest
import torch
from streets import streets as _streets

from estimators.classical import HarmonicInpainter, ScanlineInpainter
from estimators.learned import MeanEnsembleInpainter
from estimators.base import BaseInpainter
from estimators.learned._output import MAX_OUTPUT_DEPTH, MIN_HOLE_DEPTH, bound_output
from estimators.learned import BlendInpainter
from estimators.learned import ContextBlendInpainter
from estimators.learned import UNetInpainter
from estimators.learned import PriorUNetInpainter
from inpaintenv.data import ArrayDataset
from inpaintenv.conventions import reconstruction_problem
from inpaintenv.evaluate import evaluate
from inpaintenv.exceptions import InvalidTypeError, MethodOutputError
from inpaintenv.metrics import frame_metrics

UNET = dict(width=4, depth=2, batch_size=2, epochs=1, random_state=0, num_threads=1)


@pytest.fixture(scope="module")
def frames() -> np.ndarray:
    return _streets()


@pytest.fixture(scope="module")
def data(frames) -> ArrayDataset:
    return ArrayDataset(frames, groups=list("aaaabc"))


def _corrupt(gt: np.ndarray) -> np.ndarray:
    x = gt.copy()
    x[..., 10:25, 30:70] = np.nan
    return x


@pytest.fixture(scope="module")
def learned(data) -> dict[str, object]:
    blend = BlendInpainter(width=8, layers=1, epochs=1, masks_per_frame=1, pixels_per_frame=200, batch_pixels=64,
                           num_threads=1, tta=False).fit(data)
    context = ContextBlendInpainter(n_context=2, context_widths=(4, 8), width=8, layers=1, epochs=1,
                                    masks_per_frame=1, keep=(1.0,), pixels_per_frame=200, batch_frames=3,
                                    batch_pixels=64, num_threads=1).fit(data)
    return {
        "unet": UNetInpainter(**UNET).fit(data),
        "prior": PriorUNetInpainter(width=4, levels=1, batch_size=2, max_steps=2, random_state=0,
                                    num_threads=1).fit(data),
        "blend": blend,
        "context": context,
        "ensemble": MeanEnsembleInpainter.from_fitted([("context", context), ("blend", blend)]),
    }


def test_a_briefly_trained_unet_whose_raw_output_is_not_positive_fills_every_hole_pixel(data, frames):
    est = UNetInpainter(**UNET).fit(data)
    with torch.no_grad():  # a net that has learned nothing useful yet: raw output <= 0 m everywhere
        est.model_.head.bias.fill_(-100.0)
    gt = frames[:2]
    x = _corrupt(gt)
    raw = est._forward(est.model_, x, torch.device("cpu"))
    hole = np.isnan(x)
    assert (raw[hole] <= 0).all()
    out = est.predict(x)
    assert (out[hole] >= MIN_HOLE_DEPTH).all() and (out[hole] > 0).all()
    np.testing.assert_array_equal(out[x > 0], x[x > 0])
    # The benchmark's default refuses 0 m in a hole as unfilled: these are estimates.
    frame_metrics(out, gt, hole, unfilled="error")


@pytest.mark.parametrize("name", ["unet", "prior", "blend", "context", "ensemble"])
def test_every_hole_pixel_is_positive(learned, frames, name):
    x = _corrupt(frames[:2])
    out = learned[name].predict(x)
    assert (out[np.isnan(x)] >= MIN_HOLE_DEPTH).all()


@pytest.mark.parametrize("name", ["unet", "prior", "blend", "context", "ensemble"])
def test_a_frame_without_any_measurement_is_left_unfilled_as_classical_methods_leave_it(learned, frames, name):
    x = _corrupt(frames[:2])
    x[1] = np.nan  # nothing measured in the second frame
    x[1, :5] = 0.0  # (no-measurement pixels are not measurements either)
    out = learned[name].predict(x)
    for classical in (HarmonicInpainter(), ScanlineInpainter()):
        np.testing.assert_array_equal(out[1], classical.predict(x)[1])
    assert (out[1] == 0).all()
    assert (out[0][np.isnan(x[0])] >= MIN_HOLE_DEPTH).all()  # its neighbour in the batch is filled
    assert (learned[name].predict(np.full((24, 40), np.nan, np.float32)) == 0).all()


def test_the_floor_changes_only_hole_pixels_below_it():
    x = np.array([[[np.nan, 5.0, np.nan, 0.0, np.nan]]], np.float32)
    pred = np.array([[[-1.0, 5.0, 0.002, 0.0, 7.5]]], np.float32)
    out = bound_output(pred, x)
    np.testing.assert_array_equal(out, np.array([[[MIN_HOLE_DEPTH, 5.0, MIN_HOLE_DEPTH, 0.0, 7.5]]], np.float32))
    assert out.dtype == np.float32
    assert np.isnan(bound_output(np.array([[[np.nan, 1.0]]], np.float32), np.array([[[np.nan, 1.0]]], np.float32))[0, 0, 0])


def test_the_cap_changes_only_pixels_above_the_trained_range():
    x = np.array([[[np.nan, 5.0, np.nan, 0.0]]], np.float32)
    pred = np.array([[[303.0, 5.0, 80.25, 1e6]]], np.float32)
    np.testing.assert_array_equal(bound_output(pred, x),
                                  np.array([[[MAX_OUTPUT_DEPTH, 5.0, 80.25, MAX_OUTPUT_DEPTH]]], np.float32))


def test_a_briefly_trained_unet_far_beyond_any_training_depth_is_capped(data, frames):
    # Such a U-Net predicted 303 m; evaluate, fill and the env refuse that.
    est = UNetInpainter(**UNET, keep_observed=False).fit(data)
    with torch.no_grad():
        est.model_.head.bias.fill_(100.0)
    x = _corrupt(frames[:2])
    assert est._forward(est.model_, x, torch.device("cpu")).max() > MAX_OUTPUT_DEPTH
    out = est.predict(x)
    assert out.max() <= MAX_OUTPUT_DEPTH and reconstruction_problem(out) is None
    assert np.isfinite(est.score(frames[:2]))


class _Overshoot(BaseInpainter):
    """Fills holes at 5 m but puts 300 m where nothing was measured (where no truth exists either)."""

    _stateless = True

    def _predict_batch(self, X):
        return np.where(np.isnan(X), 5.0, np.where(X > 0, X, 300.0)).astype(np.float32)


def test_score_refuses_what_evaluate_refuses(frames):
    gt = frames[:2]
    assert (gt == 0).any()
    with pytest.raises(MethodOutputError, match="_Overshoot.*above the bound"):
        _Overshoot().score(gt)
    with pytest.raises(MethodOutputError, match="above the bound"):
        evaluate(_Overshoot(), ArrayDataset(gt), protocol="rect-v1")


class _Complex(BaseInpainter):
    _stateless = True

    def _predict_batch(self, X):
        return np.nan_to_num(X, nan=5.0).astype(np.complex64)


def test_complex_output_is_refused_at_the_estimator_boundary(frames):
    with pytest.raises(InvalidTypeError, match="complex"):
        _Complex().predict(_corrupt(frames[:1]))
