"""``inpaintenv fill --confidence``: a per-pixel interval beside each filled depth file."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from estimators.classical import ScanlineInpainter
from estimators.intervals import ConformalIntervalInpainter
from inpaintenv.cli import main
from inpaintenv.conventions import DEPTH_LIMIT
from inpaintenv.data import SyntheticStreets, read_depth_file, read_depth_png, write_depth_png
from inpaintenv.exceptions import InvalidInputError
from inpaintenv.files.lock import LOCK_FILE
from inpaintenv.filling import fill
from inpaintenv.filling.ledger import LEDGER
from inpaintenv.filling.write import LOW_FLOOR

SHAPE = (64, 96)


def frames(n: int, seed: int = 0) -> list[np.ndarray]:
    """Synthetic LiDAR-like frames with 5 % depth noise, so that a fill errs inside its holes."""
    ds = SyntheticStreets(n=n, frame_shape=SHAPE, kind="velodyne_raw", seed=seed)
    rng = np.random.default_rng(seed)
    return [(np.asarray(ds[i]) * (1 + 0.05 * rng.standard_normal(SHAPE))).clip(0).astype(np.float32)
            for i in range(n)]


@pytest.fixture(scope="module")
def calibration(tmp_path_factory) -> tuple[Path, ConformalIntervalInpainter]:
    """scanline calibrated on 6 synthetic frames of 3 drives, saved to cal.json."""
    wrapper = ConformalIntervalInpainter(ScanlineInpainter(), spread_method="nearest").fit(
        frames(6, seed=1), groups=[f"d{k // 2}" for k in range(6)])
    path = tmp_path_factory.mktemp("cal") / "cal.json"
    return wrapper.save(path, base="scanline"), wrapper


def holed(seed: int = 5) -> np.ndarray:
    x = frames(1, seed=seed)[0]
    x[20:40, 30:60] = np.nan
    return x


def test_interval_files_hold_the_fill_and_equal_predict_interval(calibration, tmp_path):
    path, wrapper = calibration
    x = holed()
    _npy(tmp_path / "in" / "a.npy", x)
    rc = main(["fill", str(tmp_path / "in"), "--format", "both", "--confidence", "--intervals", str(path),
               "-m", "scanline", "--out", str(tmp_path / "out"), "-q"])
    assert rc == 0
    names = sorted(p.name for p in (tmp_path / "out").iterdir() if p.name not in (LEDGER, LOCK_FILE))
    assert names == ["a.npy", "a.png", "a_high.npy", "a_high.png", "a_low.npy", "a_low.png"]
    filled, low, high = (np.load(tmp_path / "out" / f"a{s}.npy") for s in ("", "_low", "_high"))
    hole = np.isnan(x)
    assert np.isfinite(low).all() and np.isfinite(high).all()
    assert (low <= filled).all() and (filled <= high).all() and ((high - low)[hole] > 0).all()
    np.testing.assert_array_equal(low[~hole], filled[~hole])  # measured (or unmeasured 0) pixels: no width
    np.testing.assert_array_equal(high[~hole], filled[~hole])
    ref_low, ref_high = wrapper.predict_interval(x)  # the calibrated 0.9 interval of the same prediction
    # A filled pixel's low bound is at least 1/256 m (0 means "no interval"), its high at most the PNG limit.
    np.testing.assert_array_equal(low[hole], np.clip(ref_low[hole], LOW_FLOOR, DEPTH_LIMIT).astype(low.dtype))
    np.testing.assert_array_equal(high[hole], np.clip(ref_high[hole], 0, DEPTH_LIMIT).astype(high.dtype))
    # The PNGs are the same bounds rounded outward to 1/256 m, so still bounds and still ordered.
    p_low, p_fill, p_high = (read_depth_png(tmp_path / "out" / f"a{s}.png") for s in ("_low", "", "_high"))
    assert (p_low <= p_fill).all() and (p_fill <= p_high).all() and (p_low[hole] > 0).all()
    assert (p_low <= low)[hole].all() and (low - p_low)[hole].max() < 1 / 256
    assert (p_high >= high)[hole].all() and (p_high - high)[hole].max() < 1 / 256


def test_another_coverage_is_nested(calibration, tmp_path):
    path, _ = calibration
    x = holed()
    widths = {}
    for c in (0.5, 0.95):
        fill([_npy(tmp_path / "in" / "a.npy", x)], tmp_path / f"out{c}", method="scanline", format="npy",
             confidence=c, intervals=path, progress=False)
        low, high = (np.load(tmp_path / f"out{c}" / f"a{s}.npy") for s in ("_low", "_high"))
        widths[c] = (high - low)[np.isnan(x)]
    assert (widths[0.5] <= widths[0.95]).all() and widths[0.5].mean() < widths[0.95].mean()


def _npy(path: Path, x: np.ndarray) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    np.save(path, x)
    return path


def test_an_estimator_with_its_own_interval_and_resume(calibration, tmp_path):
    _, wrapper = calibration
    src = tmp_path / "in"
    for k, d in enumerate(frames(2, seed=3)):
        d[10:30, 20:50] = 0  # no data there: filled with --missing
        write_depth_png(src / f"{k}.png", d)
    report = fill([src], tmp_path / "out", method=wrapper, missing=True, confidence=0.9, progress=False)
    assert len(report.written) == 2
    (tmp_path / "out" / "1_high.png").unlink()  # a run cut short: that input is redone, the other kept
    again = fill([src], tmp_path / "out", method=wrapper, missing=True, confidence=0.9, progress=False)
    assert [p.name for p in again.written] == ["1.png"] and [p.name for p in again.skipped] == ["0.png"]
    assert (tmp_path / "out" / "1_high.png").is_file()


@pytest.mark.parametrize("args, message", [
    (["--confidence", "-m", "harmonic"], "method 'harmonic' has none: give --intervals CAL.json"),
    (["--intervals", "CAL", "-m", "scanline"], "give --confidence too"),
    (["--confidence", "1.5", "--intervals", "CAL", "-m", "scanline"], "confidence"),
    (["--confidence", "--intervals", "NOFILE", "-m", "scanline"], "calibration file not found"),
    (["--confidence", "--intervals", "CAL", "-m", "harmonic"], "calibrated for a ScanlineInpainter"),
])
def test_bad_confidence_options_are_one_line(calibration, tmp_path, capsys, args, message):
    path, _ = calibration
    _npy(tmp_path / "in" / "a.npy", holed())
    args = [str(path) if a == "CAL" else str(tmp_path / "none.json") if a == "NOFILE" else a for a in args]
    rc = main(["fill", str(tmp_path / "in"), *args, "--out", str(tmp_path / "out"), "-q"])
    err = capsys.readouterr().err
    assert rc != 0 and message in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


def test_an_input_named_like_an_interval_file_is_refused(calibration, tmp_path):
    path, _ = calibration
    _npy(tmp_path / "in" / "a.npy", holed())
    _npy(tmp_path / "in" / "a_low.npy", holed())
    with pytest.raises(InvalidInputError, match="would be written to the same output"):
        fill([tmp_path / "in"], tmp_path / "out", method="scanline", format="npy", confidence=0.9,
             intervals=path, progress=False)


def test_scanline_fills_with_its_shipped_interval_without_a_calibration_file(tmp_path):
    from estimators.intervals import release_intervals

    x = holed()
    _npy(tmp_path / "in" / "a.npy", x)
    rc = main(["fill", str(tmp_path / "in"), "--format", "npy", "--confidence", "-m", "scanline",
               "--out", str(tmp_path / "out"), "-q"])
    assert rc == 0
    filled, low, high = (np.load(tmp_path / "out" / f"a{s}.npy") for s in ("", "_low", "_high"))
    shipped = release_intervals("scanline")
    hole = np.isnan(x)
    np.testing.assert_array_equal(filled[hole], shipped.predict(x)[hole])
    ref_low, ref_high = shipped.predict_interval(x)
    np.testing.assert_array_equal(low[hole], ref_low[hole])
    np.testing.assert_array_equal(high[hole], ref_high[hole])
    assert ((high - low)[hole] > 0).all()


@pytest.mark.kitti
@pytest.mark.slow
@pytest.mark.parametrize("method", ["kitti-ensemble-v1", "scanline"])
def test_confidence_on_the_official_scans_writes_every_file_and_reads_back(kitti_root, tmp_path, method):
    """Lower bounds below 1/256 m failed whole frames: each file is written, and read back."""
    frames_dir = kitti_root / "depth_selection" / "val_selection_cropped" / "velodyne_raw"
    inputs = sorted(frames_dir.glob("*.png"))
    report = fill([frames_dir], tmp_path, method=method, missing=True, confidence=0.9, format="both", progress=False)
    assert report.ok, report.failed
    assert len(report.written) == len(inputs) > 0
    for source in inputs:
        for suffix in (".png", ".npy"):
            d, low, high = (read_depth_file(tmp_path / f"{source.stem}{s}{suffix}") for s in ("", "_low", "_high"))
            filled = d > 0
            assert ((low > 0) == filled).all() and ((high > 0) == filled).all()  # 0: no interval, nothing else
            assert (low <= d).all() and (d <= high).all() and (low[filled] >= LOW_FLOOR).all()


@pytest.mark.kitti
def test_the_default_asks_a_scans_interval_of_its_scan_route_never_of_the_map_release(kitti_root, tmp_path):
    """pretrained fills a scan with its scan route; --confidence must not swap in the map release's
    fill and interval (it did: up to 25 m apart). Where the scan route ships its calibration (on
    scans), every file of the official scans is written and the depth is the plain fill's, bit for bit."""
    from estimators.intervals import shipped_intervals
    from inpaintenv.methods.learned import SCAN_DEFAULT

    frames_dir = kitti_root / "depth_selection" / "val_selection_cropped" / "velodyne_raw"
    inputs = sorted(frames_dir.glob("*.png"))
    if SCAN_DEFAULT not in shipped_intervals():  # a scan route without a calibration: one line naming it
        lines = []
        report = fill([inputs[0]], tmp_path, method="pretrained", missing=True, confidence=0.9, progress=False,
                      log=lines.append)
        assert not report.written and "no calibrated interval for a single scan" in report.failed[0][1]
        return
    report = fill([frames_dir], tmp_path / "ci", method="pretrained", missing=True, confidence=0.9, progress=False)
    plain = fill([frames_dir], tmp_path / "plain", method="pretrained", missing=True, progress=False)
    assert report.ok and plain.ok, (report.failed, plain.failed)
    assert len(report.written) == len(inputs) > 0
    for source in inputs:
        scan = read_depth_png(source)
        d, low, high = (read_depth_file(tmp_path / "ci" / f"{source.stem}{s}.png") for s in ("", "_low", "_high"))
        np.testing.assert_array_equal(d, read_depth_file(tmp_path / "plain" / f"{source.stem}.png"))
        filled = (d > 0) & (scan == 0)
        assert filled.any() and (low <= d).all() and (d <= high).all()
        assert ((high - low)[filled] > 0).all() and (low[filled] >= LOW_FLOOR).all()
