"""score and the scoring batches on a dataset of single scans: the scan task, as evaluate scores it."""

from __future__ import annotations

import numpy as np
import pytest

from estimators.base import iter_scoring_batches
from estimators.classical import HarmonicInpainter
from inpaintenv.data import SyntheticStreets, method_input
from inpaintenv.evaluate import evaluate
from inpaintenv.masks import get_protocol


@pytest.fixture(scope="module")
def scans():
    return SyntheticStreets(n=3, seed=5, frame_shape=(64, 192), input="scan")


def test_score_on_scans_is_minus_evaluates_unmeasured_rmse(scans):
    est = HarmonicInpainter()
    rows = evaluate(est, scans, protocol="rect-v1", seeds=[0], progress=False).rows
    expected = -float(np.mean([row["unmeasured_rmse"] for row in rows]))
    assert est.score(scans) == pytest.approx(expected, rel=1e-6)


def test_the_batches_of_a_scan_dataset_are_the_scans_with_the_hole_cut_scored_on_every_unmeasured_pixel(scans):
    (x, gt, scored), = list(iter_scoring_batches(scans, protocol="rect-v1", seed=0))
    inputs, truth = scans.load_pairs(range(len(scans)))
    hole = get_protocol("rect-v1").masks(scans.frame_shape, 0, range(len(scans)))
    np.testing.assert_array_equal(x, method_input(inputs, hole, "scan"))
    np.testing.assert_array_equal(gt, truth)
    np.testing.assert_array_equal(scored, np.isnan(x))
    assert (scored & ~hole).any()  # unmeasured pixels outside the hole are scored too


def test_map_batches_are_unchanged():
    maps = SyntheticStreets(n=2, seed=5, frame_shape=(64, 192))
    (x, gt, hole), = list(iter_scoring_batches(maps, protocol="rect-v1", seed=0))
    expected = maps.load_batch([0, 1])
    np.testing.assert_array_equal(gt, expected)
    expected = expected.copy()
    expected[hole] = np.nan
    np.testing.assert_array_equal(x, expected)
    np.testing.assert_array_equal(hole, get_protocol("rect-v1").masks(maps.frame_shape, 0, range(2)))
