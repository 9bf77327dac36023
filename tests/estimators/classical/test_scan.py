"""The shared row/column scans give the same numbers as each feature computed alone."""

from __future__ import annotations

import numpy as np
import pytest

from estimators._scan import fill_empty_rows
from estimators.classical._base import in_inverse_depth
from estimators.classical.scanline import scanline_fill
from estimators.candidates import (
    _FILLS,
    AVAILABLE_CANDIDATES,
    candidate_fills,
    endpoint_values,
    gap_distances,
    prior_features,
)


def _reference(x: np.ndarray) -> np.ndarray:
    """prior_features built from the single-feature functions, one at a time."""
    known = x > 0
    v = np.where(known, x, 0.0).astype(np.float32)
    vertical = lambda a, k: scanline_fill(a.T, k.T).T
    fills = {
        "scanline": scanline_fill(v, known),
        "scanline-inverse": in_inverse_depth(scanline_fill, v, known),
        "vertical": vertical(v, known),
        "vertical-inverse": in_inverse_depth(vertical, v, known),
    }
    return np.concatenate([
        np.stack([v, np.isnan(x), known]).astype(np.float32),
        np.stack(list(fills.values())), gap_distances(known), endpoint_values(v, known),
    ])


def _frames(rng: np.random.Generator) -> list[np.ndarray]:
    out = []
    for density, shape in [(0.3, (24, 40)), (0.05, (31, 17)), (0.9, (8, 64))]:
        x = (rng.random(shape) * 60 + 1).astype(np.float32)
        x[rng.random(shape) > density] = 0.0
        x[2:6, 3:12] = np.nan
        x[:, 5] = 0.0  # an empty column
        x[shape[0] // 2] = 0.0  # an empty row inside
        out.append(x)
    lonely = np.zeros((9, 11), np.float32)
    lonely[4, 6] = 12.0
    lonely[6:8] = np.nan
    out += [lonely, np.full((5, 7), np.nan, np.float32)]
    return out


def test_fused_features_equal_the_single_feature_functions(rng):
    names = ("scanline", "scanline-inverse", "vertical", "vertical-inverse")
    for x in _frames(rng):
        got = prior_features(x, names, gaps=True, endpoints=True)
        np.testing.assert_array_equal(got, _reference(x))


def test_whole_frame_fills_in_the_worker_thread_keep_order_and_numbers(rng):
    # harmonic and the row bands run beside the scans (another thread); the channels must
    # come back in the order asked for, equal to each fill function called alone
    names = ("harmonic-inverse", "scanline", "row-median", "vertical-inverse", "harmonic", "row-far")
    for x in _frames(rng):
        known = x > 0
        v = np.where(known, x, 0.0).astype(np.float32)
        alone = np.stack([_FILLS[n](v, known) for n in names]).astype(np.float32)
        np.testing.assert_array_equal(candidate_fills(x, names), alone)
        got = prior_features(x, names, gaps=True, endpoints=True)
        np.testing.assert_array_equal(got[3:3 + len(names)], alone)
        np.testing.assert_array_equal(got[3 + len(names):], np.concatenate([gap_distances(known),
                                                                            endpoint_values(v, known)]))


@pytest.mark.kitti
def test_fused_features_on_a_real_frame(kitti_root):
    from inpaintenv.data import KittiDepth
    from inpaintenv.masks import get_protocol

    gt = KittiDepth(kitti_root, split="train")[7]
    x = np.where(get_protocol("rect-v1").mask(gt.shape, 0, 7), np.nan, gt).astype(np.float32)
    names = ("scanline", "scanline-inverse", "vertical", "vertical-inverse")
    np.testing.assert_array_equal(prior_features(x, names, gaps=True, endpoints=True), _reference(x))
    # the other candidates still come out of their own functions
    assert prior_features(x, AVAILABLE_CANDIDATES).shape == (3 + len(AVAILABLE_CANDIDATES), *x.shape)


def test_fill_empty_rows_interpolates_between_filled_rows():
    filled = np.array([[0.0], [2.0], [0.0], [0.0], [8.0], [0.0]], np.float32)
    ok = np.array([False, True, False, False, True, False])
    out = fill_empty_rows(filled, ok)
    np.testing.assert_allclose(out[:, 0], [2.0, 2.0, 4.0, 6.0, 8.0, 8.0])
    # nothing filled: returned as is
    np.testing.assert_array_equal(fill_empty_rows(filled, np.zeros(6, bool)), filled)


def test_candidate_names_are_checked_once_for_functions_and_estimators():
    x = np.full((8, 8), 5.0, np.float32)
    x[2:4, 2:4] = np.nan
    for bad in ("scanline", (), ("telepathy",)):
        with pytest.raises(ValueError, match="candidates must be a non-empty tuple from"):
            prior_features(x, bad)
    assert prior_features(x, ["scanline"]).shape == (4, 8, 8)  # a list is fine
