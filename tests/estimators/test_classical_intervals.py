"""The interval calibrations shipped for classical fills (``scanline-intervals``): no torch, no fold models."""

from __future__ import annotations

import json

import numpy as np
import pytest

from estimators.intervals import ConformalIntervalInpainter, release_intervals, shipped_intervals
from estimators.intervals._bases import CLASSICAL_FILLS
from estimators.intervals._releases import _intervals_dir
from inpaintenv.benchmark.suites import method_kind, registry_kind
from inpaintenv.data import SyntheticStreets
from inpaintenv.masks import get_protocol
from inpaintenv.registry import available_methods, is_learned, make_method
from release_checks import check_shipped_interval

SHIPPED = [name for name in shipped_intervals() if name in CLASSICAL_FILLS]


def holed(protocol: str, seed: int = 4) -> np.ndarray:
    x = np.asarray(SyntheticStreets(n=1, frame_shape=(96, 320), seed=seed)[0], dtype=np.float32)
    x[get_protocol(protocol).mask(x.shape, seed=0, index=0)] = np.nan
    return x


def test_the_strongest_classical_fill_ships_one_registered_as_classical():
    assert "scanline" in SHIPPED
    assert "scanline-intervals" in available_methods()
    assert registry_kind("scanline-intervals") == "classical" and not is_learned("scanline-intervals")


@pytest.mark.parametrize("name", SHIPPED)
def test_it_predicts_as_the_fill_and_its_interval_holds_it(name):
    wrapped = make_method(f"{name}-intervals")
    assert type(wrapped) is ConformalIntervalInpainter and method_kind(f"{name}-intervals", wrapped) == "classical"
    cal = wrapped.calibration_
    x = holed(cal["protocol"])
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


def test_overrides_reach_the_fill():
    assert release_intervals("scanline", n_jobs=2).estimator.n_jobs == 2


@pytest.mark.kitti
def test_its_calibration_drives_are_drives_of_the_slice(kitti_root):
    from inpaintenv.data import KittiDepth

    drives = {str(g) for g in KittiDepth(kitti_root, split="train").groups}
    for name in SHIPPED:
        assert set(release_intervals(name).calibration_["drives"]) <= drives
