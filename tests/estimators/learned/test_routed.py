"""The default for both input kinds: each frame routed by its measured density or by ``input``."""

from __future__ import annotations

import numpy as np
import pytest

from estimators.classical import HarmonicInpainter, NearestInpainter
from estimators.learned._routed import SCAN_DENSITY, InputRoutedInpainter, measured_density
from inpaintenv.data import SyntheticStreets
from inpaintenv.data.inputs import method_input
from inpaintenv.exceptions import InpaintenvError
from inpaintenv.masks import get_protocol

SHAPE = (64, 192)


def _inputs(kind: str, protocol: str, n: int = 3) -> np.ndarray:
    frames = SyntheticStreets(n=n, seed=1, frame_shape=SHAPE, input=kind)
    holes = get_protocol(protocol).masks(SHAPE, 0, range(n))
    return method_input(frames.load_input_batch(range(n)), holes, kind)


def _router(**kw) -> InputRoutedInpainter:
    return InputRoutedInpainter(map_method=NearestInpainter(), scan_method=HarmonicInpainter(),
                                scan_name="harmonic", map_name="nearest", **kw)


@pytest.mark.parametrize("protocol", ["rect-v1", "mixed-v1", "lidar-dropout-v1"])
def test_synthetic_maps_and_scans_go_to_their_method(protocol):
    est = _router()
    scans, maps = _inputs("scan", "densify-v1"), _inputs("map", protocol)
    assert all(measured_density(np.nan_to_num(x)) <= SCAN_DENSITY for x in scans)
    assert all(est.choose(x) == "harmonic" for x in scans)
    assert all(est.choose(x) == "nearest" for x in maps)
    both = np.concatenate([scans[:1], maps[:1]])
    out = est.predict(both)
    assert est.routed_to_ == ["harmonic", "nearest"]
    np.testing.assert_array_equal(out[0], HarmonicInpainter().predict(both[0]))
    np.testing.assert_array_equal(out[1], NearestInpainter().predict(both[1]))


def test_an_explicit_input_overrides_the_density():
    maps = _inputs("map", "rect-v1")
    est = _router(input="scan")
    est.predict(maps)
    assert est.routed_to_ == ["harmonic"] * len(maps)


@pytest.mark.parametrize("bad", [{"input": "lidar"}, {"threshold": 1.5}, {"threshold": True}])
def test_bad_parameters_are_one_clear_error(bad):
    with pytest.raises(InpaintenvError, match="input|threshold"):
        _router(**bad).predict(_inputs("scan", "densify-v1", 1))


def test_pretrained_fills_a_scan_with_the_scan_default_and_a_map_with_the_release():
    pytest.importorskip("torch")
    from estimators.learned.releases import DEFAULT_RELEASE, SCAN_DEFAULT
    from inpaintenv.registry import make_method

    est = make_method("pretrained")
    assert est.choose(_inputs("scan", "densify-v1", 1)[0]) == SCAN_DEFAULT
    assert est.choose(_inputs("map", "rect-v1", 1)[0]) == DEFAULT_RELEASE


@pytest.mark.kitti
def test_pretrained_is_never_worse_than_harmonic_on_the_official_scans(kitti_root):
    """KITTI's own validation selection: every scan routed as a scan, and no worse than harmonic
    on the ground-truth pixels the scan did not measure."""
    pytest.importorskip("torch")
    from inpaintenv.data import KittiDepth
    from inpaintenv.registry import make_method

    if not (kitti_root / "depth_selection").is_dir():
        pytest.skip("the KITTI slice has no depth_selection/")
    frames = KittiDepth(kitti_root, split="val_selection", camera="both", input="scan")
    scans, gt = frames.load_pairs(range(len(frames)))
    x = method_input(scans, np.zeros(scans.shape, bool), "scan")
    est = make_method("pretrained")
    ours, base = est.predict(x), HarmonicInpainter().predict(x)
    assert len(est.routed_to_) == len(frames) and set(est.routed_to_) == {est.scan_name}
    scored = (gt > 0) & np.isnan(x)
    for a, b, g, m in zip(ours, base, gt, scored):
        assert np.sqrt(np.mean((a[m] - g[m]) ** 2)) <= np.sqrt(np.mean((b[m] - g[m]) ** 2)) + 1e-6
