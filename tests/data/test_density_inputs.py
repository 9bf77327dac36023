"""The density variants of a scan as input kinds: a sparser LiDAR simulated from the 64-beam scan.

Each variant's input is a subset of the frame's scan (every k-th laser ring, or a seeded
share of its points), the same whatever order or subset the frames are loaded in; it
composes with every hole protocol; its inputs are pinned by golden hashes.
"""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

from inpaintenv.data import ArrayDataset, SyntheticStreets, method_input
from inpaintenv.data.inputs import INPUTS, input_kind
from inpaintenv.data.thinning import ring_map
from inpaintenv.evaluate import evaluate
from inpaintenv.exceptions import InpaintenvError
from inpaintenv.masks import get_protocol
from inpaintenv.methods.registry import make_method

SHAPE = (128, 384)
VARIANTS = [k for k, kind in INPUTS.items() if kind.thinned]
#: sha256 (first 16 hex digits) of the float32 inputs of frames 0-2 of
#: ``SyntheticStreets(n=3, seed=0, frame_shape=(128, 384), input=<variant>)``. A failure means a
#: variant's inputs changed: restore the old behaviour and put the new one in a new version
#: (``scan-rings16-v2``); do not update the hash.
GOLDEN = {
    "scan-rings32-v1": "8a9b9ef81685309d",
    "scan-rings16-v1": "008062bd46d6c393",
    "scan-rings8-v1": "618cd08c0a004cca",
    "scan-points50-v1": "47d3eabfeee72d2a",
    "scan-points25-v1": "1ce99baa37077cc1",
    "scan-points10-v1": "5c6c6fefdd7c36f0",
}


def source(kind: str, n: int = 3) -> SyntheticStreets:
    return SyntheticStreets(n=n, seed=0, frame_shape=SHAPE, frames_per_drive=2, input=kind)


@pytest.fixture(scope="module")
def full_scans() -> np.ndarray:
    return source("scan").load_input_batch(range(3))


def test_every_variant_is_named_and_versioned():
    assert set(VARIANTS) == {"scan-rings32-v1", "scan-rings16-v1", "scan-rings8-v1", "scan-points50-v1",
                             "scan-points25-v1", "scan-points10-v1"}
    for name in VARIANTS:
        kind = input_kind(name)
        assert kind.separate and name.endswith("-v1") and kind.summary
        assert kind.label("rect-v1") == f"{name}:rect-v1" and kind.file_tag == f"__{name}"
    assert input_kind("map").label("rect-v1") == "rect-v1" and input_kind("map").file_tag == ""
    assert input_kind("scan-rings16-v1").beams == 16 and input_kind("scan-points25-v1").density == "25 % of points"
    with pytest.raises(InpaintenvError, match="scan-rings16-v1"):
        input_kind("scan-rings12-v1")


@pytest.mark.parametrize("name", VARIANTS)
def test_a_variant_keeps_a_share_of_the_scan(name, full_scans):
    kind = input_kind(name)
    thinned = source(name).load_input_batch(range(3))
    kept = thinned > 0
    np.testing.assert_array_equal(thinned[kept], full_scans[kept])  # a subset of the scan, values unchanged
    for scan, mine in zip(full_scans, kept):
        n = np.count_nonzero(scan)
        if kind.keep_fraction < 1:
            assert np.count_nonzero(mine) == round(kind.keep_fraction * n)
        else:
            assert 0.7 / kind.keep_every < np.count_nonzero(mine) / n < 1.3 / kind.keep_every


@pytest.mark.parametrize("name", ["scan-rings8-v1", "scan-points10-v1"])
def test_a_frames_input_does_not_depend_on_order_or_subset(name):
    ds = source(name, n=4)
    whole = ds.load_input_batch([0, 1, 2, 3])
    np.testing.assert_array_equal(ds[[3, 1]].load_input_batch([0, 1]), whole[[3, 1]])
    inputs, gt = ds.load_pairs([2])
    np.testing.assert_array_equal(inputs[0], whole[2])
    np.testing.assert_array_equal(gt[0], source("scan", n=4).load_pairs([2])[1][0])


def test_the_synthetic_rings_are_the_simulated_lasers(full_scans):
    """Each kept ring of a synthetic scan is one laser: its pixels lie on one curve (one row per column)."""
    ds = source("scan")
    calibration, height = ds.scan_calibration(0)
    rings = ring_map(full_scans[0], calibration, height)
    assert rings.max() + 1 >= 16
    rows, cols = np.nonzero(rings >= 0)
    order = np.lexsort((cols, rings[rows, cols]))
    r, c, g = rows[order], cols[order], rings[rows, cols][order]
    same = (g[1:] == g[:-1]) & (c[1:] - c[:-1] <= 2)
    # Neighbouring pixels of one ring seen at one depth are at most two rows apart.
    z = full_scans[0][r, c]
    flat = same & (np.abs(z[1:] - z[:-1]) < 0.05 * z[1:])
    assert np.mean(np.abs(np.diff(r))[flat] > 2) < 0.01


@pytest.mark.parametrize("name", sorted(GOLDEN))
def test_golden_inputs(name):
    h = hashlib.sha256()
    for frame in source(name).load_input_batch(range(3)):
        h.update(np.ascontiguousarray(frame, dtype="<f4").tobytes())
    assert h.hexdigest()[:16] == GOLDEN[name]


@pytest.mark.parametrize("protocol", ["rect-v1", "densify-v1"])
def test_a_variant_composes_with_a_hole_protocol(protocol):
    ds = source("scan-rings16-v1")
    inputs, gt = ds.load_pairs(range(3))
    hole = get_protocol(protocol).masks(ds.frame_shape, 0, range(3))
    x = method_input(inputs, hole, ds.input_kind)
    assert np.isnan(x[hole]).all() and (x[~np.isnan(x)] > 0).all()
    np.testing.assert_array_equal(~np.isnan(x), (inputs > 0) & ~hole)
    result = evaluate(make_method("harmonic"), ds, protocol, [0], progress=False)
    assert {r["input_kind"] for r in result.rows} == {"scan-rings16-v1"} and len(result.rows) == 3
    full = evaluate(make_method("harmonic"), source("scan"), protocol, [0], progress=False)
    # Fewer measurements: more pixels to fill and score.
    assert all(a["unmeasured_count"] > b["unmeasured_count"] for a, b in zip(result.rows, full.rows))


def test_rings_need_a_calibration_points_do_not():
    frames = np.full((2, 16, 24), 10.0, dtype=np.float32)
    scans = np.where(np.random.default_rng(0).random((2, 16, 24)) < 0.3, 5.0, 0.0).astype(np.float32)
    ds = ArrayDataset(frames, inputs=scans)
    ds.input_kind = "scan-rings16-v1"
    with pytest.raises(InpaintenvError, match="calibration"):
        ds.input_frame(0)
    ds.input_kind = "scan-points50-v1"
    assert np.count_nonzero(ds.input_frame(0)) == round(0.5 * np.count_nonzero(scans[0]))
