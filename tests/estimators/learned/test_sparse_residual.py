"""SparseResidualInpainter: ``harmonic`` plus a learned correction, trained on scans thinned by laser rings."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch
from sklearn.base import clone

from estimators.candidates import residual_features
from estimators.classical import HarmonicInpainter
from estimators.learned import SparseResidualInpainter, load
from estimators.learned._checkpoint import CheckpointError
from inpaintenv.data import ArrayDataset, ConcatDataset, SyntheticStreets
from inpaintenv.data.inputs import method_input
from inpaintenv.data.thinning import thin_scan_by_rings
from inpaintenv.exceptions import InvalidInputError, OutOfRangeError

STREETS = dict(n=4, seed=2, frame_shape=(64, 160), frames_per_drive=2)


@pytest.fixture(scope="module")
def scans():
    return SyntheticStreets(**STREETS, input="scan")


@pytest.fixture(scope="module")
def beams16():
    """The same frames at 16 beams: inputs (NaN = to fill) and ground truth."""
    inputs, gt = SyntheticStreets(**STREETS, input="scan-rings16-v1").load_pairs(range(STREETS["n"]))
    return method_input(inputs, np.zeros(inputs.shape, bool), "scan"), gt


@pytest.fixture(scope="module")
def fitted(scans):
    return SparseResidualInpainter(epochs=5, pixels_per_frame=1000, num_threads=1).fit(scans)


def test_scan_calibration_thins_a_synthetic_scan_to_its_16_beam_variant(scans, beams16):
    both = ConcatDataset([scans, scans])
    calibration, height = both.scan_calibration(-1)  # a wrapped dataset asks its part
    scan = scans.input_frame(3)
    thinned = thin_scan_by_rings(scan, calibration, 4, laser_height=height)
    assert 0 < (thinned > 0).sum() < (scan > 0).sum() / 2
    np.testing.assert_array_equal(np.where(thinned > 0, thinned, np.nan), beams16[0][3])
    with pytest.raises(OutOfRangeError, match="frame index 8 out of range"):
        both.scan_calibration(8)


def test_beats_harmonic_at_16_beams_on_its_frames_and_keeps_every_measurement(fitted, beams16):
    x, gt = beams16
    pred, harmonic = fitted.predict(x), HarmonicInpainter().predict(x)
    measured, todo = x > 0, np.isnan(x)
    np.testing.assert_array_equal(pred[measured], x[measured])
    assert pred.dtype == np.float32 and np.isfinite(pred).all() and (pred[todo] > 0).all()
    scored = todo & (gt > 0)

    def rmse(p):
        return float(np.sqrt(np.mean((p[scored] - gt[scored]) ** 2)))

    assert rmse(pred) < 0.95 * rmse(harmonic)
    np.testing.assert_array_equal(fitted.predict(x[1]), pred[1])  # one frame as in a batch
    assert fitted.n_pixels_ == 3 * 4 * 1000 and fitted.training_frames_ == 4
    assert fitted.feature_mean_.shape == fitted.feature_std_.shape == (1 + 5 + 4 + 4 + 2,)


def test_predict_is_harmonic_plus_the_network_on_the_standardised_features(fitted, beams16):
    """The chunked prediction (features pixel last, standardised in place, read as transposed
    views) gives what the network gives on the plain (P, C) features, for any thread count."""
    x = beams16[0][2]
    todo = np.isnan(x)
    feats, harmonic = residual_features(x, tuple(fitted.fills), todo)
    with torch.inference_mode():
        net = fitted.model_(torch.from_numpy((feats - fitted.feature_mean_) / fitted.feature_std_)).numpy()
    for threads in (1, 2):
        pred = clone(fitted).set_params(predict_threads=threads)
        pred.__dict__.update({k: v for k, v in fitted.__dict__.items() if k.endswith("_")})
        np.testing.assert_allclose(pred.predict(x)[todo], harmonic + net, rtol=0, atol=1e-5)
    assert fitted.predict_threads == 1 and np.abs(net).max() > 1e-3  # a network that does correct


def test_the_same_prediction_with_or_without_worker_threads(fitted, beams16, monkeypatch):
    """Features and network chunks split over a worker thread (a free core) give the same numbers."""
    from concurrent.futures import ThreadPoolExecutor

    import estimators.candidates as candidates
    import estimators.learned._sparse_residual as module
    from estimators._residual_features import _Inline

    x = beams16[0][:2]
    for where in (candidates, module):
        monkeypatch.setattr(where, "overlap", lambda wanted=True: _Inline())
    inline = fitted.predict(x)
    for where in (candidates, module):
        monkeypatch.setattr(where, "overlap", lambda wanted=True: ThreadPoolExecutor(max_workers=1))
    np.testing.assert_array_equal(fitted.predict(x), inline)


def test_save_and_load_predict_the_same(fitted, beams16, tmp_path):
    path = fitted.save(tmp_path / "model")
    config = json.loads((path / "config.json").read_text())
    assert config["class"] == "SparseResidualInpainter" and len(config["standardise"]["std"]) == 16
    again = load(path)
    assert type(again) is SparseResidualInpainter and again.get_params() == fitted.get_params()
    np.testing.assert_array_equal(again.predict(beams16[0]), fitted.predict(beams16[0]))


@pytest.mark.parametrize("key, value, match", [
    ("mean", [0.0] * 15, "standardise 'mean' must be 16 numbers"),
    ("std", [1.0] * 15 + [0.0], "standardise 'std' must be positive"),
    ("std", [1.0] * 15 + [float("inf")], "standardise 'std' must be finite"),
])
def test_a_checkpoint_with_bad_standardisation_is_refused(fitted, key, value, match):
    config, weights = fitted.to_config()
    config["standardise"][key] = value
    with pytest.raises(CheckpointError, match=match):
        SparseResidualInpainter.from_config(config, weights, "model")


@pytest.mark.parametrize("params, match", [
    (dict(fills=("harmonic", "no-such-fill")), "fills must be a non-empty tuple"),
    (dict(fills="nearest"), "fills must be a non-empty tuple"),
    (dict(rings=()), "rings must be a non-empty tuple of ring steps"),
    (dict(rings=(0, 4)), "rings must be a non-empty tuple of ring steps"),
    (dict(rings=(2.5,)), "rings must be"),
    (dict(width=0), "width must be"),
    (dict(lr=0.0), "lr must be"),
    (dict(pixels_per_frame=-1), "pixels_per_frame must be"),
    (dict(shrink=0.0), r"shrink must be a number in \(0, 1\]"),
    (dict(shrink=1.5), "shrink must be"),
    (dict(shrink=float("nan")), "shrink must be"),
])
def test_each_bad_parameter_is_one_clear_error(scans, params, match):
    with pytest.raises(InvalidInputError, match=match):
        SparseResidualInpainter(**params).fit(scans)


def test_a_map_dataset_or_one_without_calibrations_is_refused():
    maps = SyntheticStreets(n=2, frame_shape=(32, 64))
    with pytest.raises(InvalidInputError, match="learns from LiDAR scans.*input kind 'map'"):
        SparseResidualInpainter().fit(maps)
    gt = maps.load_batch([0, 1])
    no_calibration = ArrayDataset(gt, inputs=np.where(np.arange(32)[:, None] % 2 == 0, gt, 0.0))
    with pytest.raises(InvalidInputError, match="no calibration of its scans"):
        SparseResidualInpainter(rings=(1, 4)).fit(no_calibration)
    # The scan as it is needs no calibration.
    assert SparseResidualInpainter(rings=(1,), epochs=1, pixels_per_frame=50).fit(no_calibration).n_pixels_ > 0


def test_clone_keeps_the_parameters_and_changed_model_parameters_are_refused(fitted, beams16):
    twin = clone(fitted)
    assert twin.get_params() == fitted.get_params() and not hasattr(twin, "model_")
    changed = clone(fitted).set_params(width=8)
    changed.__dict__.update({k: v for k, v in fitted.__dict__.items() if k.endswith("_")})
    with pytest.raises(InvalidInputError, match="width changed since the weights were made"):
        changed.predict(beams16[0][0])


def test_shrink_scales_the_correction_at_predict_and_is_saved(fitted, beams16, tmp_path):
    import copy

    x = beams16[0]
    harmonic, full = HarmonicInpainter().predict(x), fitted.predict(x)
    half = copy.copy(fitted).set_params(shrink=0.5)
    todo = np.isnan(x)
    # harmonic plus half the correction; the measurements kept
    np.testing.assert_allclose(half.predict(x)[todo], (harmonic + 0.5 * (full - harmonic))[todo], atol=1e-4)
    np.testing.assert_array_equal(half.predict(x)[~todo], x[~todo])
    assert fitted.shrink == 1.0 and np.array_equal(fitted.predict(x), full)  # the copy leaves it as it was
    again = load(half.save(tmp_path / "half"))
    assert again.shrink == 0.5 and np.array_equal(again.predict(x), half.predict(x))
    with pytest.raises(InvalidInputError, match="shrink must be"):
        copy.copy(fitted).set_params(shrink=0.0).predict(x)


def test_shrink_changes_neither_fit_nor_the_weights(scans):
    kw = dict(epochs=1, pixels_per_frame=200, num_threads=1)
    a, b = SparseResidualInpainter(**kw).fit(scans), SparseResidualInpainter(shrink=0.25, **kw).fit(scans)
    assert a.history_ == b.history_
    for name, value in a.model_.state_dict().items():
        assert np.array_equal(value.numpy(), b.model_.state_dict()[name].numpy())
