"""The interval calibrations shipped with releases (estimators/pretrained/intervals/)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from estimators.intervals import ConformalIntervalInpainter, release_intervals, shipped_intervals
from estimators.intervals._bases import CLASSICAL_FILLS
from estimators.intervals._calibration import calibration_protocols
from estimators.intervals._releases import _intervals_dir
from estimators.learned import load_release
from inpaintenv.methods.learned import DEFAULT_RELEASE
from inpaintenv.cli import main
from inpaintenv.data import SyntheticStreets, write_depth_png
from inpaintenv.exceptions import InvalidInputError
from inpaintenv.masks import get_protocol
from inpaintenv.methods.registry import make_method
from release_checks import check_shipped_interval


@pytest.fixture(scope="module")
def wrapped() -> ConformalIntervalInpainter:
    return release_intervals()


@pytest.fixture(scope="module")
def holed() -> np.ndarray:
    x = np.asarray(SyntheticStreets(n=1, frame_shape=(96, 320), seed=3)[0], dtype=np.float32)
    x[get_protocol("rect-v1").mask(x.shape, seed=0, index=1)] = np.nan
    return x


def test_the_default_release_ships_a_calibration_registered_as_pretrained_intervals(wrapped):
    assert DEFAULT_RELEASE in shipped_intervals()
    assert type(make_method(f"{DEFAULT_RELEASE}-intervals")) is ConformalIntervalInpainter
    assert type(wrapped.estimator) is type(load_release())
    # pretrained-intervals routes like pretrained: a map's interval is this calibration's.
    routed = make_method("pretrained-intervals")
    assert type(routed.interval_method("map")) is ConformalIntervalInpainter
    assert routed.interval_method("map").calibration_ == wrapped.calibration_


def test_its_calibration_is_out_of_fold_on_drives_each_fold_model_never_saw(wrapped):
    cal = wrapped.calibration_
    folds = cal["out_of_fold"]
    assert len(folds) >= 2 and cal["coverage"] == 0.9 and cal["protocol"] == "rect-v1"
    drives = [d for f in folds for d in f["drives"]]
    assert sorted(drives) == cal["drives"] and len(set(drives)) == len(drives)  # each drive calibrates once
    for f in folds:
        assert f["training_drives"] and not set(f["drives"]) & set(f["training_drives"])
        assert f["n_pixels"] > 0
    assert cal["n_pixels"] == sum(f["n_pixels"] for f in folds) == wrapped.n_calibration_pixels_
    # The release itself saw them all: only out-of-fold residuals can calibrate it.
    assert set(cal["drives"]) <= set(wrapped.estimator.training_drives_)
    raw = json.loads((_intervals_dir() / f"{DEFAULT_RELEASE}.json").read_text())
    assert raw["base"] == DEFAULT_RELEASE and raw["params"]["spread_method"] == "scanline"


def test_prediction_is_the_release_bit_for_bit_and_the_interval_holds_it(wrapped, holed):
    check_shipped_interval(wrapped, holed, load_release().predict(holed))


def test_fill_confidence_with_the_default_method(tmp_path, holed, wrapped):
    depth = np.nan_to_num(holed, nan=0.0)
    write_depth_png(tmp_path / "in" / "f.png", depth)
    np.save(tmp_path / "mask.npy", np.isnan(holed))
    rc = main(["fill", str(tmp_path / "in"), "--holes", str(tmp_path / "mask.npy"), "--format", "npy",
               "--confidence", "--out", str(tmp_path / "out"), "-q"])
    assert rc == 0
    filled, low, high = (np.load(tmp_path / "out" / f"f{s}.npy") for s in ("", "_low", "_high"))
    hole = np.isnan(holed)
    assert (low <= filled).all() and (filled <= high).all() and ((high - low)[hole] > 0).all()


@pytest.mark.parametrize("name", [n for n in shipped_intervals() if n not in CLASSICAL_FILLS])
def test_every_shipped_release_calibration_never_saw_its_calibration_drives(name):
    # A classical fill's (scanline) saw no drive at all: tests/estimators/test_classical_intervals.py.
    wrapped = release_intervals(name)
    cal = wrapped.calibration_
    raw = json.loads((_intervals_dir() / f"{name}.json").read_text())
    assert raw["base"] == name and make_method(f"{name}-intervals").calibration_ == cal
    if "out_of_fold" in cal:  # each drive by a fold model that never saw it
        assert all(not set(f["drives"]) & set(f["training_drives"]) for f in cal["out_of_fold"])
    else:  # calibrated directly: the release never saw a calibration drive
        assert cal["drives"] and not set(cal["drives"]) & set(wrapped.estimator.training_drives_)
    # Drive 0001's maps and scans are the official frames reported: never calibrated on, in or out of fold.
    assert "2011_09_26_drive_0001_sync" not in cal["drives"]
    protocols = calibration_protocols(cal["protocol"])  # "densify-v1+rect-v1" pools two
    if any(p.task == "unmeasured" for p in protocols):  # densify-v1: calibrated on scans
        from inpaintenv.data import method_input

        scan = SyntheticStreets(n=1, frame_shape=(96, 320), seed=4, input="scan").load_input_batch([0])[0]
        x = method_input(scan, protocols[-1].mask(scan.shape, seed=0, index=0), "scan")
    else:
        x = np.asarray(SyntheticStreets(n=1, frame_shape=(96, 320), seed=4)[0], dtype=np.float32)
        x[protocols[-1].mask(x.shape, seed=0, index=0)] = np.nan
    check_shipped_interval(wrapped, x, load_release(name).predict(x))


def test_fill_confidence_finds_a_release_calibration_under_its_other_names(tmp_path, holed):
    if "kitti-mixed-v1" not in shipped_intervals():
        pytest.skip("kitti-mixed-v1 ships no calibration")
    write_depth_png(tmp_path / "in" / "f.png", np.nan_to_num(holed, nan=0.0))
    np.save(tmp_path / "mask.npy", np.isnan(holed))
    rc = main(["fill", str(tmp_path / "in"), "--holes", str(tmp_path / "mask.npy"), "-m", "blend-pretrained-mixed",
               "--confidence", "0.8", "--out", str(tmp_path / "out"), "-q"])
    assert rc == 0 and (tmp_path / "out" / "f_high.png").is_file()


def test_a_release_without_a_calibration_is_named():
    with pytest.raises(InvalidInputError, match="has no shipped interval calibration"):
        release_intervals("no-such-release")


def _scans() -> np.ndarray:
    from inpaintenv.data import method_input

    inputs, _ = SyntheticStreets(n=2, frame_shape=(64, 192), seed=2, input="scan").load_pairs([0, 1])
    return method_input(inputs, np.zeros(inputs.shape, bool), "scan")


def test_pretrained_intervals_gives_a_scan_the_interval_of_its_scan_route_by_name():
    """The scan route's calibration is the one shipped for SCAN_DEFAULT, around the route's own
    method: its fill is pretrained's bit for bit."""
    from inpaintenv.methods.learned import SCAN_DEFAULT

    if SCAN_DEFAULT not in shipped_intervals():
        pytest.skip(f"{SCAN_DEFAULT} ships no calibration")
    routed, x = make_method("pretrained-intervals"), _scans()
    assert routed.interval_method("scan").calibration_ == release_intervals(SCAN_DEFAULT).calibration_
    pred = make_method("pretrained").predict(x)
    np.testing.assert_array_equal(routed.predict(x), pred)
    assert routed.routed_to_ == [SCAN_DEFAULT] * len(x)
    check_shipped_interval(routed.interval_method("scan"), x, pred)


def test_a_scan_default_without_a_calibration_gets_no_interval(monkeypatch):
    """Looked up by name: a scan default that ships none is refused, never given another's calibration."""
    from inpaintenv.exceptions import InpaintenvError
    from inpaintenv.methods.learned import SCAN_DEFAULT

    import estimators.intervals._releases as shipped_calibrations

    every = shipped_calibrations.shipped_intervals
    scan_default = SCAN_DEFAULT
    monkeypatch.setattr(shipped_calibrations, "shipped_intervals",
                        lambda: [k for k in every() if k != scan_default])
    routed = make_method("pretrained-intervals")
    with pytest.raises(InpaintenvError, match=f"{SCAN_DEFAULT!r} has no shipped interval calibration"):
        routed.predict_interval(_scans())


def test_pretrained_intervals_loads_only_the_route_a_frame_takes(monkeypatch):
    """As pretrained: intervals on scans never load the map release (and its calibration); a map's load it."""
    import estimators.learned
    from estimators.learned import _releases
    from inpaintenv.methods.learned import SCAN_DEFAULT

    loaded = []
    real = _releases.load_release

    def counting(name, **kw):
        loaded.append(name)
        return real(name, **kw)

    monkeypatch.setattr(_releases, "load_release", counting)
    monkeypatch.setattr(estimators.learned, "load_release", counting)
    routed, x = make_method("pretrained-intervals"), _scans()
    assert loaded == []
    low, high = routed.predict_interval(x, 0.9)
    assert loaded == [SCAN_DEFAULT] and (low <= high).all()
    dense = np.where(np.isnan(x[:1]), 20.0, x[:1])
    dense[:, : dense.shape[1] // 2, : dense.shape[2] // 2] = np.nan  # a dense frame with a hole: a map
    routed.predict(dense)
    assert loaded == [SCAN_DEFAULT, DEFAULT_RELEASE]


@pytest.mark.parametrize("name", ["pretrained", "pretrained-intervals"])
def test_the_default_gives_each_frame_the_shipped_interval_of_its_route(name, holed, wrapped):
    """pretrained and pretrained-intervals: predict_interval and predict(X, return_std=True) on a batch
    of a map and scans, each frame's interval the one shipped for its route, the fill pretrained's."""
    from inpaintenv.methods.learned import SCAN_DEFAULT
    from inpaintenv.metrics import normal_quantile

    if SCAN_DEFAULT not in shipped_intervals():
        pytest.skip(f"{SCAN_DEFAULT} ships no calibration")
    scans = _scans()
    batch = np.concatenate([holed[None, :64, :192], scans])
    routed = make_method(name)
    pred = make_method("pretrained").predict(batch)
    check_shipped_interval(routed, batch, pred)
    assert routed.routed_to_ == [DEFAULT_RELEASE] + [SCAN_DEFAULT] * len(scans)
    low, high = routed.predict_interval(batch, coverage=0.8)
    for k, own in [(0, wrapped), *((k, release_intervals(SCAN_DEFAULT)) for k in range(1, len(batch)))]:
        own_low, own_high = own.predict_interval(batch[k], coverage=0.8)
        np.testing.assert_array_equal(low[k], own_low)
        np.testing.assert_array_equal(high[k], own_high)
    # std is the calibrated 90 % half-width over z(0.9): pred + z std is the interval's top.
    _, std = routed.predict(batch, return_std=True)
    _, high90 = routed.predict_interval(batch, coverage=0.9)
    np.testing.assert_allclose(pred + normal_quantile(0.9) * std, high90, rtol=1e-5, atol=1e-4)


def test_benchmark_scores_the_default_s_interval(tmp_path):
    argv = ["benchmark", "-m", "pretrained", "--n-frames", "2", "--frame-shape", "64", "192", "--holdout", "0",
            "--figure-frames", "0", "--quiet", "--out", str(tmp_path / "run"), "--interval-coverage", "0.9"]
    assert main(argv) == 0
    rows = json.loads((tmp_path / "run" / "results.json").read_text())["rows"]
    assert rows and all(0 <= r["hole_coverage"] <= 1 and r["hole_interval_width"] > 0 for r in rows)


def _sparse_scan() -> np.ndarray:
    """A synthetic scan thinned to 8 laser rings, as pretrained's sparse route takes it."""
    from inpaintenv.data import method_input

    ds = SyntheticStreets(n=1, frame_shape=(128, 384), input="scan-rings8-v1")
    inputs = ds.load_input_batch([0])
    return method_input(inputs, np.zeros(inputs.shape, bool), ds.input)


def test_a_sparse_scan_s_route_without_a_calibration_is_named_with_its_kind(monkeypatch):
    """Without the sparse route's own calibration, asking a sparse scan's interval is one error
    naming the kind of frame and the route (never harmonic's map calibration: it ships none)."""
    import estimators.intervals._releases as shipped_calibrations
    from inpaintenv.exceptions import InpaintenvError

    monkeypatch.setattr(shipped_calibrations, "ROUTE_INTERVALS", {})
    x = _sparse_scan()
    routed = make_method("pretrained")
    routed.predict(x)
    if routed.routed_kinds_ != ["sparse"] or routed.sparse_name in shipped_intervals():
        pytest.skip("this frame is not routed as a sparse scan, or its method ships a calibration")
    with pytest.raises(InpaintenvError, match=rf"for a sparse scan \(route {routed.sparse_name}\).*no shipped"):
        routed.predict_interval(x)
    with pytest.raises(InpaintenvError, match="for a sparse scan"):
        routed.predict(x, return_std=True)


def test_the_sparse_route_s_calibration_is_its_own_and_loaded_only_when_asked(monkeypatch):
    """A sparse scan's interval is the calibration shipped for the sparse route (intervals/routes/),
    loaded when a sparse scan's interval is first asked: not by filling it, not by a 64-beam
    scan's interval. It registers no <fill>-intervals method for maps."""
    import estimators.intervals._releases as shipped_calibrations
    from inpaintenv.methods.learned import SPARSE_DEFAULT
    from inpaintenv.methods.registry import available_methods

    route_file = _intervals_dir() / "routes" / f"{shipped_calibrations.ROUTE_INTERVALS[SPARSE_DEFAULT]}.json"
    assert route_file.is_file()
    assert SPARSE_DEFAULT not in shipped_intervals() and f"{SPARSE_DEFAULT}-intervals" not in available_methods()
    asked = []
    real = shipped_calibrations._route_path
    monkeypatch.setattr(shipped_calibrations, "_route_path", lambda name: asked.append(name) or real(name))
    x = _sparse_scan()
    routed = make_method("pretrained")
    pred = routed.predict(x)
    assert routed.routed_kinds_ == ["sparse"] and routed.routed_to_ == [SPARSE_DEFAULT] and asked == []
    routed.predict_interval(_scans())  # a 64-beam scan's interval: the scan route's calibration only
    assert SPARSE_DEFAULT not in asked
    check_shipped_interval(routed, x, pred)
    assert asked.count(SPARSE_DEFAULT) == 1  # loaded once, then kept
    cal = ConformalIntervalInpainter.load(route_file, estimator=make_method(SPARSE_DEFAULT))
    assert routed.interval_method("sparse").calibration_ == cal.calibration_
    assert cal.calibration_["input_kind"] == "scan-rings32-v1+scan-rings16-v1+scan-rings8-v1"
    low, high = routed.predict_interval(x, coverage=0.8)
    own_low, own_high = cal.predict_interval(x, coverage=0.8)
    np.testing.assert_array_equal(low, own_low)
    np.testing.assert_array_equal(high, own_high)
