"""MeanInpainter: the per-pixel mean of classical fills."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import clone

from estimators.classical import HarmonicInpainter, IPBasicInpainter, MeanInpainter, NearestInpainter
from inpaintenv.data import SyntheticStreets, method_input
from inpaintenv.exceptions import InvalidInputError, InvalidTypeError


@pytest.fixture(scope="module")
def scans():
    frames = SyntheticStreets(n=2, seed=3, frame_shape=(64, 192), input="scan")
    scan, gt = frames.load_pairs([0, 1])
    return method_input(scan, np.zeros(scan.shape, bool), "scan"), gt


def test_is_the_mean_of_its_fills_and_keeps_measurements(scans):
    x, _ = scans
    pred = MeanInpainter().predict(x)
    expected = (HarmonicInpainter().predict(x).astype(np.float64)
                + IPBasicInpainter(large_hole_kernel=None).predict(x)) / 2
    np.testing.assert_allclose(pred, expected, rtol=1e-6, atol=1e-5)
    measured = x > 0
    np.testing.assert_array_equal(pred[measured], x[measured])


def test_names_and_instances_give_the_same_fill(scans):
    x, _ = scans
    by_name = MeanInpainter(methods=("harmonic", "nearest")).predict(x)
    by_instance = MeanInpainter(methods=(HarmonicInpainter(), NearestInpainter())).predict(x)
    np.testing.assert_array_equal(by_name, by_instance)
    assert clone(MeanInpainter(methods=("harmonic", "nearest"))).get_params()["methods"] == ("harmonic", "nearest")


def test_on_synthetic_scans_it_beats_its_worse_member(scans):
    x, gt = scans
    scored = (gt > 0) & np.isnan(x)

    def rmse(pred):
        return float(np.sqrt(np.mean((pred[scored] - gt[scored]) ** 2)))

    members = [rmse(HarmonicInpainter().predict(x)), rmse(IPBasicInpainter(large_hole_kernel=None).predict(x))]
    assert rmse(MeanInpainter().predict(x)) < max(members)


@pytest.mark.parametrize("methods, error, match", [
    (("harmonic",), InvalidInputError, "at least two"),
    ("harmonic", InvalidInputError, "at least two"),
    (("harmonic", "nope"), InvalidInputError, "'nope' is not a classical method"),
    (("harmonic", 3), InvalidTypeError, "name or instance"),
    (("harmonic", MeanInpainter()), InvalidTypeError, "name or instance"),
    (("harmonic", HarmonicInpainter(iterations=0)), InvalidInputError,
     r"^methods\[1\] \(HarmonicInpainter\): iterations must be an integer >= 1, got 0$"),
])
def test_bad_methods_are_one_clear_error(scans, methods, error, match):
    with pytest.raises(error, match=match):
        MeanInpainter(methods=methods).predict(scans[0])
