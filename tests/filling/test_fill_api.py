"""``inpaintenv.filling.fill`` called from Python, on synthetic files (no KITTI needed).

What a run writes and where, its ledger, the rerun that skips, another method's output
refused without ``overwrite``, ``missing=`` / ``fill_all=`` as the command's ``--missing`` /
``--fill-all``, and a LiDAR scan in and points out. The command's own behaviour is in
``tests/cli/test_cli_fill*.py``.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest
from point_checks import check_points_added

from estimators.classical import ScanlineInpainter
from inpaintenv.cli import main
from inpaintenv.data import (
    Calibration,
    SyntheticStreets,
    project_scan,
    read_calibration,
    read_depth_file,
    read_scan,
    write_depth_file,
    write_points_bin,
)
from inpaintenv.exceptions import InvalidInputError
from inpaintenv.filling import NO_HOLES, FillReport, fill, fill_depth
from inpaintenv.filling.ledger import LEDGER
from inpaintenv.filling.view import sensor_view

SHAPE = (48, 120)
BOX = (30, 10, 70, 30)  # columns 30..69, rows 10..29


def sparse_frames(n: int) -> list[np.ndarray]:
    """Synthetic single-scan maps whose top rows are sky (no beam reaches them)."""
    streets = SyntheticStreets(n=n, frame_shape=SHAPE, kind="velodyne_raw", seed=3)
    frames = [streets[i] for i in range(n)]
    for f in frames:
        f[:12] = 0
    return frames


def box_mask(shape: tuple[int, int] = SHAPE) -> np.ndarray:
    x0, y0, x1, y1 = BOX
    mask = np.zeros(shape, bool)
    mask[y0:y1, x0:x1] = True
    return mask


def digest(folder: Path) -> dict[str, str]:
    return {p.relative_to(folder).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture
def pngs(tmp_path) -> tuple[Path, list[np.ndarray]]:
    """``in/a/0001.png``, ``in/b/0002.png``: two drives' maps as KITTI PNGs."""
    frames = sparse_frames(2)
    for rel, f in zip(("a/0001.png", "b/0002.png"), frames):
        write_depth_file(tmp_path / "in" / rel, f)
    return tmp_path / "in", [read_depth_file(tmp_path / "in" / r) for r in ("a/0001.png", "b/0002.png")]


def run(inputs, out, **kwargs) -> FillReport:
    lines: list[str] = []
    report = fill(inputs, out, progress=False, log=lines.append, **kwargs)
    assert [why for _, why in report.failed] == lines  # every failure is logged, once
    return report


def test_each_input_is_written_at_its_relative_path_as_fill_depth_fills_it(pngs, tmp_path):
    folder, frames = pngs
    before = digest(folder)
    report = run([folder], tmp_path / "out", method="nearest", boxes=[BOX], format="both")
    assert report.ok and sorted(report.written) == sorted(folder.rglob("*.png")) and not report.skipped
    assert report.summary() == "fill: 2 written, 0 skipped, 0 failed"
    assert digest(folder) == before  # inputs never change
    for rel, depth in zip(("a/0001", "b/0002"), frames):
        want = fill_depth("nearest", depth, box_mask())
        got = np.load(tmp_path / "out" / f"{rel}.npy")
        np.testing.assert_array_equal(got, want)
        np.testing.assert_array_equal(read_depth_file(tmp_path / "out" / f"{rel}.png"), np.rint(want * 256) / 256)
        keep = ~box_mask()
        np.testing.assert_array_equal(got[keep], depth[keep])  # measured and unmeasured pixels as they were
        assert (got[box_mask()] > 0).all() and np.isfinite(got).all()


def test_npy_with_nan_is_filled_in_its_own_dtype(tmp_path):
    depth = sparse_frames(1)[0].astype(np.float64)
    depth[box_mask()] = np.nan
    (tmp_path / "in").mkdir()
    np.save(tmp_path / "in" / "f.npy", depth)
    assert run([tmp_path / "in" / "f.npy"], tmp_path / "out", method="scanline", format="npy").ok
    got = np.load(tmp_path / "out" / "f.npy")
    assert got.dtype == np.float64
    np.testing.assert_array_equal(got, fill_depth("scanline", depth))


def test_the_ledger_records_each_input_and_a_rerun_skips_it(pngs, tmp_path):
    folder, _ = pngs
    out = tmp_path / "out"
    run([folder], out, method="nearest", boxes=[BOX])
    lines = [json.loads(line) for line in (out / LEDGER).read_text().splitlines()]
    # Each input's intent (before its outputs), then its record (after them).
    assert [{**r, "intent": True} for r in lines[1::2]] == lines[::2]
    records = [r for r in lines if "intent" not in r]
    assert sorted(r["outputs"][0] for r in records) == ["a/0001.png", "b/0002.png"]
    for r in records:
        source = folder / Path(r["outputs"][0])
        assert r["input"] == {"path": str(source.resolve()), "size": source.stat().st_size,
                              "mtime_ns": source.stat().st_mtime_ns}
        assert r["recipe"]["method"] == "nearest"
    written = digest(out)
    again = run([folder], out, method="nearest", boxes=[BOX])
    assert not again.written and sorted(again.skipped) == sorted(folder.rglob("*.png"))
    assert "2 skipped (outputs exist" in again.summary()
    assert digest(out) == written  # nothing rewritten, not even the ledger


def test_another_methods_output_is_refused_until_overwrite(pngs, tmp_path):
    folder, frames = pngs
    out = tmp_path / "out"
    run([folder], out, method="nearest", boxes=[BOX])
    made = digest(out)
    refused = run([folder], out, method="scanline", boxes=[BOX])
    assert not refused.written and not refused.ok and len(refused.failed) == 2
    for _, why in refused.failed:
        assert 'was made with method "nearest" (now "scanline")' in why and "--overwrite" in why
    assert digest(out) == made

    redone = run([folder], out, method="scanline", boxes=[BOX], overwrite=True)
    assert redone.ok and len(redone.written) == 2
    want = fill_depth("scanline", frames[0], box_mask())
    np.testing.assert_array_equal(read_depth_file(out / "a" / "0001.png"), np.rint(want * 256) / 256)
    # The next plain run of scanline is this run's own: skipped, not refused.
    assert len(run([folder], out, method="scanline", boxes=[BOX]).skipped) == 2


def test_a_file_fill_did_not_write_is_refused(pngs, tmp_path):
    folder, frames = pngs
    out = tmp_path / "out"
    write_depth_file(out / "a" / "0001.png", frames[1])  # the user's own file where an output would go
    report = run([folder], out, method="nearest", boxes=[BOX])
    assert report.written == [folder / "b" / "0002.png"]
    (source, why), = report.failed
    assert source == folder / "a" / "0001.png" and "was not written by inpaintenv fill" in why
    np.testing.assert_array_equal(read_depth_file(out / "a" / "0001.png"), frames[1])


def test_an_estimator_object_is_recorded_by_the_parameters_that_change_its_pixels(pngs, tmp_path):
    folder, _ = pngs
    out = tmp_path / "out"
    assert run([folder], out, method=ScanlineInpainter(), boxes=[BOX]).ok
    assert len(run([folder], out, method=ScanlineInpainter(n_jobs=2), boxes=[BOX]).skipped) == 2  # same pixels
    refused = run([folder], out, method=ScanlineInpainter(vertical=True), boxes=[BOX])
    assert len(refused.failed) == 2 and all("vertical" in why for _, why in refused.failed)


@pytest.mark.parametrize("fill_all", [False, True])
def test_missing_and_fill_all_are_the_commands_missing_and_fill_all(pngs, tmp_path, fill_all):
    folder, frames = pngs
    report = run([folder], tmp_path / "api", method="nearest", missing=True, fill_all=fill_all)
    assert report.ok and len(report.written) == 2
    argv = ["fill", str(folder), "--missing", *(["--fill-all"] if fill_all else []), "-m", "nearest", "-q"]
    assert main([*argv, "--out", str(tmp_path / "cli")]) == 0
    api, cli = digest(tmp_path / "api"), digest(tmp_path / "cli")
    assert {k: v for k, v in api.items() if k != LEDGER} == {k: v for k, v in cli.items() if k != LEDGER}
    depth = frames[0]
    got = read_depth_file(tmp_path / "api" / "a" / "0001.png")
    view = np.ones(SHAPE, bool) if fill_all else sensor_view(depth)
    assert (got[view] > 0).all()  # every pixel of the view is filled
    assert (got[~view] == 0).all()  # the sky above the scan stays empty unless fill_all
    assert not sensor_view(depth).all()  # the frame has a sky, or this test would not tell the two apart
    np.testing.assert_array_equal(got[depth > 0], depth[depth > 0])


def test_missing_and_fill_all_outputs_do_not_pass_for_each_other(pngs, tmp_path):
    folder, _ = pngs
    run([folder], tmp_path / "out", method="nearest", missing=True)
    refused = run([folder], tmp_path / "out", method="nearest", missing=True, fill_all=True)
    assert len(refused.failed) == 2 and all("fill_all" in why for _, why in refused.failed)


def test_fill_all_without_missing_and_nothing_to_fill_are_refused(pngs, tmp_path):
    folder, _ = pngs
    with pytest.raises(InvalidInputError, match="give missing too"):
        fill([folder], tmp_path / "out", method="nearest", fill_all=True, progress=False)
    report = run([folder], tmp_path / "out", method="nearest")
    assert not report.written and len(report.failed) == 2
    assert all(why.endswith(NO_HOLES) for _, why in report.failed)


def test_a_bad_file_fails_alone(pngs, tmp_path):
    folder, _ = pngs
    (folder / "a" / "broken.png").write_bytes(b"not a png")
    report = run([folder], tmp_path / "out", method="nearest", boxes=[BOX])
    assert len(report.written) == 2
    (source, why), = report.failed
    assert source == folder / "a" / "broken.png" and str(source) in why
    assert not (tmp_path / "out" / "a" / "broken.png").exists()


# -- a LiDAR scan ------------------------------------------------------------------------------------------

#: A camera looking along the LiDAR's x axis (LiDAR: x forward, y left, z up; camera: x right,
#: y down, z forward), 120 x 48 pixels.
CAMERA = np.array([[60.0, 0, 60, 0], [0, 60, 24, 0], [0, 0, 1, 0]]) @ np.array(
    [[0, -1, 0, 0], [0, 0, -1, 0], [1, 0, 0, 0], [0, 0, 0, 1]], dtype=float)


def synthetic_scan() -> np.ndarray:
    """A 16-beam scan of a wall 8-12 m ahead, beams from +3 to -15 degrees (the rows above are sky)."""
    az, el = np.meshgrid(np.radians(np.arange(-50, 50, 0.4)), np.radians(np.linspace(3, -15, 16)))
    x = 10 + 2 * np.sin(3 * az)
    pts = np.stack([x, x * np.tan(az), x * np.tan(el) / np.cos(az), np.full_like(x, 0.5)], -1).reshape(-1, 4)
    return pts.astype(np.float32)


def test_a_scan_is_projected_filled_and_written_back_as_points(tmp_path):
    calib = Calibration(CAMERA, (SHAPE[1], SHAPE[0]), "odometry")
    original = synthetic_scan()
    (tmp_path / "scans").mkdir()
    write_points_bin(tmp_path / "scans" / "s.bin", original)
    assert np.array_equal(read_scan(tmp_path / "scans" / "s.bin"), original)
    report = run([tmp_path / "scans"], tmp_path / "out", method="nearest", calibration=calib, boxes=[BOX],
                 format="npy", points="bin")
    assert report.ok and report.written == [tmp_path / "scans" / "s.bin"]
    depth = project_scan(original, calib)
    assert depth.shape == SHAPE and (depth > 0).any()
    filled = np.load(tmp_path / "out" / "s.npy")
    mask = box_mask()
    np.testing.assert_array_equal(filled[~mask], depth[~mask])
    np.testing.assert_array_equal(filled, fill_depth("nearest", depth, mask))
    out = read_scan(tmp_path / "out" / "s.bin")
    check_points_added(out, original, filled, mask, calib)


def test_a_scan_with_missing_fills_its_band_not_the_sky(tmp_path):
    calib = Calibration(CAMERA, (SHAPE[1], SHAPE[0]), "odometry")
    write_points_bin(tmp_path / "s.bin", synthetic_scan())
    assert run([tmp_path / "s.bin"], tmp_path / "out", method="nearest", calibration=calib, missing=True).ok
    depth = project_scan(synthetic_scan(), calib)
    got = read_depth_file(tmp_path / "out" / "s.png")
    view = sensor_view(depth)
    assert (got[view] > 0).all() and (got[~view] == 0).all()
    assert (~view[:15]).all()  # no beam reaches the top rows


def test_a_scan_without_a_calibration_fails_alone(pngs, tmp_path):
    folder, _ = pngs
    write_points_bin(folder / "s.bin", synthetic_scan())
    report = run([folder], tmp_path / "out", method="nearest", boxes=[BOX])
    assert len(report.written) == 2
    (source, why), = report.failed
    assert source == folder / "s.bin" and "needs its calibration" in why


@pytest.mark.kitti
def test_a_real_scan_fills_at_its_calibrations_size(kitti_raw_root, tmp_path):
    day = kitti_raw_root / "2011_09_26"
    scan = next(iter(sorted(day.glob("*_sync/velodyne_points/data/*.bin"))), None)
    if scan is None:
        pytest.skip(f"no scan under {day}")
    calib = read_calibration(day)
    report = run([scan], tmp_path / "out", method="scanline", calibration=calib, missing=True)
    assert report.ok
    got = read_depth_file(tmp_path / "out" / scan.with_suffix(".png").name)
    depth = project_scan(read_scan(scan), calib)
    assert got.shape == (calib.size[1], calib.size[0]) == depth.shape
    np.testing.assert_array_equal(got[depth > 0], depth[depth > 0])
    assert (got[sensor_view(depth)] > 0).all()


@pytest.mark.parametrize("given, says", [
    ({"on_error": "ignore"}, "on_error must be 'continue' or 'stop'"),
    ({"batch_size": 0}, "batch_size must be >= 1, got 0"),
    ({"confidence": 1.5}, "confidence"),
    ({"intervals": "cal.json"}, "give --confidence too"),
    ({"fill_all": True}, "give missing too"),
    ({"size": (1242, 375)}, "give calibration too"),  # size and camera alone were ignored in Python
    ({"camera": 3}, "give calibration too"),
    ({"input": "lidar"}, "input \\(--input\\) must be one of"),
    ({"boxes": [(5, 5, 5, 9)]}, "0 <= x0 < x1"),
])
def test_fill_options_are_checked_once_when_made(given, says):
    from inpaintenv.filling import FillOptions

    with pytest.raises(InvalidInputError, match=says):
        FillOptions(**given)


def test_fill_options_object_and_keywords_fill_alike(pngs, tmp_path):
    import dataclasses

    from inpaintenv.filling import FillOptions

    folder, _ = pngs
    options = FillOptions(boxes=[tuple(np.array(BOX))], missing=True, format="both", progress=False)
    assert options.boxes == (BOX,) and all(type(v) is int for v in options.boxes[0])
    with pytest.raises(dataclasses.FrozenInstanceError):
        options.missing = False  # checked once: never changed after
    assert fill([folder], tmp_path / "object", method="nearest", options=options).ok
    assert run([folder], tmp_path / "keywords", method="nearest", boxes=[BOX], missing=True, format="both").ok
    written = {name: sha for name, sha in digest(tmp_path / "object").items() if name != LEDGER}
    assert written and written == {n: s for n, s in digest(tmp_path / "keywords").items() if n != LEDGER}
    # Keywords beside options replace its fields, checked again.
    with pytest.raises(InvalidInputError, match="give missing too"):
        fill([folder], tmp_path / "x", method="nearest", options=options, missing=False, fill_all=True)
    with pytest.raises(TypeError, match="unexpected keyword argument 'hole'"):
        fill([folder], tmp_path / "x", method="nearest", hole="masks/")
