"""BlendInpainter trained on single scans: the input is the scan (hole cut, unmeasured NaN), the
target every ground-truth pixel that was to be filled."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("torch")

from estimators.candidates import candidate_fills, window_extreme  # noqa: E402
from estimators.learned import BlendInpainter  # noqa: E402
from inpaintenv.data import SyntheticStreets  # noqa: E402
from inpaintenv.data.inputs import method_input  # noqa: E402

SHAPE = (48, 160)
SCAN_CANDIDATES = ("harmonic", "ipbasic", "nearest", "window-near", "window-far")


def _blend(**kw) -> BlendInpainter:
    params = dict(candidates=SCAN_CANDIDATES, masks_per_frame=1, pixels_per_frame=400, epochs=2, batch_pixels=256,
                  width=8, tta=False)
    return BlendInpainter(**{**params, **kw})


def test_scan_training_pixels_are_the_unmeasured_ground_truth_not_only_the_hole():
    frames = SyntheticStreets(n=2, seed=0, frame_shape=SHAPE, input="scan")
    x, y = _blend(protocol="densify-v1", pixels_per_frame=10**6).training_pixels(frames, seed=0)
    scans, gt = frames.load_pairs(range(2))
    # densify-v1 cuts no hole: every ground-truth pixel the scan did not measure is a target.
    assert len(y) == int(((gt > 0) & (scans <= 0)).sum())
    maps = SyntheticStreets(n=2, seed=0, frame_shape=SHAPE, input="map")
    assert len(_blend(protocol="densify-v1").training_pixels(maps, seed=0)[1]) == 0  # a map has nothing to fill


def test_rect_holes_in_a_scan_give_half_the_pixels_from_the_hole():
    frames = SyntheticStreets(n=1, seed=0, frame_shape=SHAPE, input="scan")
    x, y = _blend(protocol="rect-v1", pixels_per_frame=200).training_pixels(frames, seed=0)
    assert len(y) == 200 and np.isfinite(x).all()


def test_a_blend_fitted_on_scans_fills_every_unmeasured_pixel():
    frames = SyntheticStreets(n=3, seed=2, frame_shape=SHAPE, input="scan")
    est = _blend(protocol="rect-v1").fit(frames)
    scans, gt = frames.load_pairs(range(3))
    x = method_input(scans, np.zeros(scans.shape, bool), "scan")
    out = est.predict(x)
    assert np.isfinite(out).all() and (out[np.isnan(x)] > 0).all()
    np.testing.assert_array_equal(out[~np.isnan(x)], x[~np.isnan(x)])


def test_window_candidates_bound_the_measurements_in_reach():
    x = np.full((20, 30), np.nan, np.float32)
    x[::4, ::5] = np.arange(1, 31, dtype=np.float32).reshape(5, 6)
    known = x > 0
    values = np.nan_to_num(x)
    near, far = window_extreme(values, known, far=False), window_extreme(values, known, far=True)
    assert (near <= far).all() and np.isfinite(near).all() and near.max() <= 30 and near.min() >= 1
    np.testing.assert_array_equal(near[known], x[known])
    fills = candidate_fills(x, SCAN_CANDIDATES)
    assert fills.shape == (len(SCAN_CANDIDATES), 20, 30) and (fills > 0).all()
