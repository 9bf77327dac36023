"""The interval calibrations shipped for classical fills (``scanline-intervals``): no torch, no fold models."""

from __future__ import annotations

import json

import numpy as np
import pytest

from estimators.intervals import ConformalIntervalInpainter, release_intervals, shipped_intervals
from estimators.intervals._bases import CLASSICAL_FILLS
from estimators.intervals._releases import _intervals_dir
from inpaintenv.benchmark.suites import method_kind, registry_kind
from inpaintenv.data import SyntheticStreets, method_input
from inpaintenv.masks import get_protocol
from inpaintenv.methods.registry import available_methods, is_learned, make_method
from release_checks import check_shipped_interval

SHIPPED = [name for name in shipped_intervals() if name in CLASSICAL_FILLS]


def holed(protocol: str, seed: int = 4, input_kind: str = "map") -> np.ndarray:
    """A synthetic input of the calibration's kind: a map with the protocol's hole, or a scan with it cut out."""
    frames = SyntheticStreets(n=1, frame_shape=(96, 320), seed=seed, input=input_kind)
    inputs, _ = frames.load_pairs([0])
    return method_input(inputs, get_protocol(protocol).masks(inputs.shape[1:], 0, [0]), input_kind)[0]


def test_the_strongest_classical_fill_ships_one_registered_as_classical():
    assert "scanline" in SHIPPED
    assert "scanline-intervals" in available_methods()
    assert registry_kind("scanline-intervals") == "classical" and not is_learned("scanline-intervals")


@pytest.mark.parametrize("name", SHIPPED)
def test_it_predicts_as_the_fill_and_its_interval_holds_it(name):
    wrapped = make_method(f"{name}-intervals")
    assert type(wrapped) is ConformalIntervalInpainter and method_kind(f"{name}-intervals", wrapped) == "classical"
    cal = wrapped.calibration_
    x = holed(cal["protocol"], input_kind=cal.get("input_kind", "map"))
    check_shipped_interval(wrapped, x, make_method(name).predict(x))


@pytest.mark.parametrize("name", SHIPPED)
def test_it_is_calibrated_directly_and_records_on_what(name):
    # A classical fill saw no drive: every calibration drive is new to it, no fold model needed.
    cal = release_intervals(name).calibration_
    raw = json.loads((_intervals_dir() / f"{name}.json").read_text())
    assert raw["base"] == name and raw["params"]["weighting"] == "frame"
    assert "out_of_fold" not in cal and cal["coverage"] == 0.9 and cal["weighting"] == "frame"
    assert len(set(cal["drives"])) == len(cal["drives"]) >= 2
    assert cal["n_frames"] >= len(cal["drives"]) and cal["n_pixels"] > cal["n_frames"]
    # Drive 0001's maps and scans are the official frames reported: never calibrated on.
    assert "2011_09_26_drive_0001_sync" not in cal["drives"]


def test_overrides_reach_the_fill():
    assert release_intervals("scanline", n_jobs=2).estimator.n_jobs == 2


@pytest.mark.kitti
def test_its_calibration_drives_are_drives_of_the_slice(kitti_root):
    from inpaintenv.data import KittiDepth

    drives = {str(g) for g in KittiDepth(kitti_root, split="train").groups}
    for name in SHIPPED:
        assert set(release_intervals(name).calibration_["drives"]) <= drives


def test_the_scan_default_ships_one_calibrated_on_scans_never_on_the_official_frames():
    from inpaintenv.methods.learned import SCAN_DEFAULT

    if SCAN_DEFAULT not in SHIPPED:
        pytest.skip(f"the scan default {SCAN_DEFAULT} ships no classical calibration")
    cal = release_intervals(SCAN_DEFAULT).calibration_
    assert cal["input_kind"] == "scan" and cal["protocol"] == "densify-v1"
    assert not [d for d in cal["drives"] if d == "2011_09_26_drive_0001_sync" or "_0002_" in d or "_9101_" in d]


@pytest.mark.kitti
def test_its_interval_covers_about_its_coverage_on_the_official_scans(kitti_root):
    """val_selection's scans were never calibrated on: the 90 % interval of the scan default
    holds about 90 % of the unmeasured ground-truth pixels there (frames alike)."""
    from estimators.base import iter_scoring_batches
    from inpaintenv.methods.learned import SCAN_DEFAULT
    from inpaintenv.data import KittiDepth

    if SCAN_DEFAULT not in SHIPPED or not (kitti_root / "depth_selection").is_dir():
        pytest.skip("no scan calibration or no depth_selection/")
    wrapped = release_intervals(SCAN_DEFAULT)
    frames = KittiDepth(kitti_root, split="val_selection", camera="both", input="scan")
    covered = []
    for x, gt, scored in iter_scoring_batches(frames, protocol="densify-v1"):
        low, high = wrapped.predict_interval(x)
        for k in range(len(x)):
            m = scored[k] & (gt[k] > 0)
            covered.append(float(np.mean((low[k][m] <= gt[k][m]) & (gt[k][m] <= high[k][m]))))
    assert 0.85 <= np.mean(covered) <= 0.97
