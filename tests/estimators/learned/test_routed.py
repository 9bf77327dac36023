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
    from inpaintenv.methods.learned import DEFAULT_RELEASE, SCAN_DEFAULT
    from inpaintenv.methods.registry import make_method

    est = make_method("pretrained")
    assert est.choose(_inputs("scan", "densify-v1", 1)[0]) == SCAN_DEFAULT
    assert est.choose(_inputs("map", "rect-v1", 1)[0]) == DEFAULT_RELEASE


def test_the_scan_route_is_the_registered_scan_default():
    pytest.importorskip("torch")
    from inpaintenv.methods.learned import SCAN_DEFAULT
    from inpaintenv.methods.registry import make_method

    est = make_method("pretrained")
    assert type(est.scan_method) is type(make_method(SCAN_DEFAULT))
    assert est.scan_method.get_params() == make_method(SCAN_DEFAULT).get_params()


def _official_scan_sets(kitti_root):
    from inpaintenv.data import KittiDepth

    sets = {}
    if (kitti_root / "depth_selection").is_dir():
        sets["val_selection"] = KittiDepth(kitti_root, split="val_selection", camera="both", input="scan")
    try:
        sets["0001"] = KittiDepth(kitti_root, split="train", camera="both", input="scan",
                                  drives=["2011_09_26_drive_0001_sync"])
    except (FileNotFoundError, ValueError):
        pass
    if not sets:
        pytest.skip("the KITTI slice has no official frames with a scan")
    return sets


def _rmse_per_frame(pred, gt, scored):
    return np.array([np.sqrt(np.mean((p[m] - g[m]) ** 2)) if m.any() else np.nan for p, g, m in zip(pred, gt, scored)])


#: rect-v1 seeds of the hole task on the official scans (each (seed, frame) one unit).
HOLE_SEEDS = (0, 1, 2)


@pytest.mark.kitti
def test_pretrained_is_never_worse_than_the_classical_fills_on_the_official_scans(kitti_root):
    """KITTI's official frames with a scan (val_selection, drive 0001): every scan routed as a
    scan; no frame of val_selection worse than harmonic; on each set, the mean RMSE over frames on
    the ground-truth pixels the scan did not measure no worse than any classical fill's, and with
    rect-v1's holes cut out of the scan, the mean hole RMSE over frames and seeds below every
    classical fill's."""
    pytest.importorskip("torch")
    from inpaintenv.masks import get_protocol
    from inpaintenv.methods.classical import CLASSICAL_METHODS
    from inpaintenv.methods.registry import make_method

    rivals = [name for name, _, kwargs, _ in CLASSICAL_METHODS
              if kwargs.get("fill", "invalid") == "invalid" and name != "constant"]
    est = make_method("pretrained")
    for set_name, frames in _official_scan_sets(kitti_root).items():
        idx = list(range(0, len(frames), max(1, len(frames) // 12)))
        scans, gt = frames.load_pairs(idx)
        x = method_input(scans, np.zeros(scans.shape, bool), "scan")
        scored = (gt > 0) & np.isnan(x)
        ours = _rmse_per_frame(est.predict(x), gt, scored)
        assert est.routed_to_ == [est.scan_name] * len(idx)
        if set_name == "val_selection":
            assert (ours <= _rmse_per_frame(HarmonicInpainter().predict(x), gt, scored) + 1e-6).all()
        holes = np.concatenate([get_protocol("rect-v1").masks(gt.shape[1:], seed, idx) for seed in HOLE_SEEDS])
        x_hole = method_input(np.tile(scans, (len(HOLE_SEEDS), 1, 1)), holes, "scan")
        gt_hole = np.tile(gt, (len(HOLE_SEEDS), 1, 1))
        in_hole = holes & (gt_hole > 0)
        ours_hole = np.nanmean(_rmse_per_frame(est.predict(x_hole), gt_hole, in_hole))
        assert set(est.routed_to_) == {est.scan_name}
        for name in rivals:
            method = make_method(name)
            assert ours.mean() <= _rmse_per_frame(method.predict(x), gt, scored).mean() + 1e-6, (set_name, name)
            theirs = np.nanmean(_rmse_per_frame(method.predict(x_hole), gt_hole, in_hole))
            assert ours_hole < theirs, (set_name, name, "rect-v1", ours_hole, theirs)


class _WithInterval(NearestInpainter):
    """A map route that gives an interval: its prediction +- 1 m."""

    def predict_interval(self, X, coverage=0.9, prediction=None):
        pred = self.predict(X) if prediction is None else prediction
        return pred - 1.0, pred + 1.0


def test_an_interval_is_asked_of_each_frames_route_and_a_route_without_one_is_named():
    est = InputRoutedInpainter(map_method=_WithInterval(), scan_method=HarmonicInpainter(),
                               scan_name="harmonic", map_name="nearest")
    maps, scans = _inputs("map", "rect-v1", 2), _inputs("scan", "densify-v1", 1)
    low, high = est.predict_interval(maps, coverage=0.9)
    pred = NearestInpainter().predict(maps)
    np.testing.assert_allclose(low, pred - 1.0)
    np.testing.assert_allclose(high, pred + 1.0)
    with pytest.raises(InpaintenvError, match="no calibrated interval for a single scan yet: its route harmonic"):
        est.predict_interval(np.concatenate([maps, scans]), coverage=0.9)


def test_pretrained_intervals_routes_like_pretrained():
    pytest.importorskip("torch")
    from inpaintenv.methods.registry import is_learned, make_method

    est = make_method("pretrained-intervals")
    assert is_learned("pretrained-intervals")
    assert est.choose(_inputs("scan", "densify-v1", 1)[0]) == est.scan_name
    assert hasattr(est.map_method, "predict_interval")
