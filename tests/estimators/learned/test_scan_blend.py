"""ScanBlendInpainter: the classical mean near a scan's measurements, the learned blend far from them."""

from __future__ import annotations

import numpy as np
import pytest

from estimators.classical import MeanInpainter
from estimators.learned import ScanBlendInpainter, load
from estimators.learned._far import far_pixels
from inpaintenv.data import SyntheticStreets
from inpaintenv.data.inputs import method_input
from inpaintenv.exceptions import InvalidInputError
from inpaintenv.masks import get_protocol

SHAPE = (96, 320)


@pytest.fixture(scope="module")
def scans():
    return SyntheticStreets(n=4, seed=1, frame_shape=SHAPE, input="scan")


@pytest.fixture(scope="module")
def fitted(scans):
    return ScanBlendInpainter(near_distance=2.0, epochs=1, pixels_per_frame=400, width=16).fit(scans)


def _scan_with_hole(scans) -> np.ndarray:
    scan, _ = scans.load_pairs([0])
    hole = get_protocol("rect-v1").mask(SHAPE, 0, 0)
    return method_input(scan[0], hole, "scan")


def test_far_pixels_are_unmeasured_beyond_the_distance_within_the_measured_rows():
    x = np.full((20, 30), np.nan, np.float32)
    x[5, 3] = x[12, 25] = 10.0
    far = far_pixels(x, 4.0)
    assert not far[:5].any() and not far[13:].any()  # outside the rows the measurements span
    assert not far[5, 3] and not far[5, 7] and far[5, 8]  # 4 px away is near, 5 px far
    assert not far_pixels(np.full((4, 4), np.nan, np.float32), 1.0).any()


def test_near_pixels_are_the_classical_mean_and_far_ones_the_blend(fitted, scans):
    x = _scan_with_hole(scans)
    pred, mean = fitted.predict(x), MeanInpainter().predict(x)
    far = far_pixels(x, fitted.near_distance)
    assert far.any() and (~far & np.isnan(x)).any()
    np.testing.assert_array_equal(pred[~far], mean[~far])
    assert not np.array_equal(pred[far], mean[far])
    assert np.isfinite(pred).all() and (pred[np.isnan(x)] > 0).all()


def test_trains_only_on_pixels_far_from_every_measurement(scans):
    est = ScanBlendInpainter(near_distance=3.0, pixels_per_frame=300)
    feats, _ = est.training_pixels(scans)
    k = len(est.candidates)
    gaps = feats[:, k : k + 4]  # each axis gap is at least the Euclidean distance to a measurement
    assert len(feats) and (gaps > 3.0).all()


def test_near_fills_must_be_candidates(scans):
    with pytest.raises(InvalidInputError, match="near_fills.*among the candidates"):
        ScanBlendInpainter(candidates=("harmonic", "nearest"), epochs=1).fit(scans)


def test_saved_and_loaded_back_predicts_the_same(fitted, scans, tmp_path):
    x = _scan_with_hole(scans)
    again = load(fitted.save(tmp_path / "scan"))
    assert type(again) is ScanBlendInpainter and again.near_fills == fitted.near_fills
    np.testing.assert_array_equal(again.predict(x), fitted.predict(x))


@pytest.mark.parametrize("density", [0.0, 0.002, 0.05, 0.6])
def test_row_context_from_one_sort_equals_the_candidates(density):
    from estimators.candidates import row_band_quantile
    from estimators.candidates import ROW_QUANTILES, row_band_quantiles

    rng = np.random.default_rng(4)
    values = rng.uniform(1, 80, (40, 90)).astype(np.float32)
    known = rng.random(values.shape) < density
    known[:6] = False  # rows without a measurement in their band
    for q, ours in zip(ROW_QUANTILES.values(), row_band_quantiles(values, known, list(ROW_QUANTILES.values()))):
        np.testing.assert_array_equal(ours, row_band_quantile(values, known, q))


def test_features_equal_the_blend_features(scans):
    from estimators.candidates import prior_features

    x = _scan_with_hole(scans)
    est = ScanBlendInpainter()
    np.testing.assert_array_equal(est._features(x), prior_features(x, est.candidates, gaps=True, endpoints=True))
