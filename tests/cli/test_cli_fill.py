"""``inpaintenv fill`` and :func:`inpaintenv.filling.fill`: files and folders in, filled files out.

Most tests use small synthetic frames and ``scanline`` (fast); one checks ``pretrained`` on one small frame; the
LiDAR tests use the real scans of ``kitti-raw`` (the ``kitti_raw_root`` fixture, skipped when absent).
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import cv2
import numpy as np
import pytest
from point_checks import check_points_added

from inpaintenv.cli import build_parser, main
from inpaintenv.data import (
    SyntheticStreets,
    project_scan,
    read_calibration,
    read_depth_file,
    read_depth_png,
    read_scan,
    write_depth_png,
)
from inpaintenv.files.lock import LOCK_FILE
from inpaintenv.filling import NO_HOLES, fill
from inpaintenv.filling.ledger import LEDGER
from inpaintenv.methods.registry import make_method


def frames(n: int, shape: tuple[int, int], seed: int = 0) -> list[np.ndarray]:
    ds = SyntheticStreets(n=n, frame_shape=shape, kind="velodyne_raw", seed=seed)
    return [np.asarray(ds[i], dtype=np.float32) for i in range(n)]


def box_mask(shape: tuple[int, int], k: int) -> np.ndarray:
    h, w = shape
    m = np.zeros(shape, bool)
    m[h // 4 + k: h // 2 + k, w // 5 + 2 * k: w // 2 + 2 * k] = True
    return m


def names(folder: Path) -> list[str]:
    """The files of ``folder`` besides the run's own (its ledger and lock)."""
    return sorted(p.name for p in folder.iterdir() if p.name not in (LEDGER, LOCK_FILE))


def hashes(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def expected(method, depth: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """What Python's predict gives: the input outside the mask, predict's values inside."""
    x = depth.astype(np.float32)
    x[mask] = np.nan
    return np.where(mask, method.predict(x), depth)


@pytest.fixture
def png_folder(tmp_path):
    """depth/<drive>/<frame>.png and masks/<drive>/<frame>.png at 64x96, 4 frames in two subfolders."""
    shape = (64, 96)
    depth_dir, mask_dir = tmp_path / "depth", tmp_path / "masks"
    items = []
    for k, d in enumerate(frames(4, shape)):
        rel = Path(f"drive_{k % 2}") / f"{k:04d}.png"
        write_depth_png(depth_dir / rel, d)
        (mask_dir / rel).parent.mkdir(parents=True, exist_ok=True)
        cv2.imwrite(str(mask_dir / rel), box_mask(shape, k).astype(np.uint8) * 255)
        items.append((rel, read_depth_png(depth_dir / rel), box_mask(shape, k)))
    return depth_dir, mask_dir, items


def test_fill_of_a_png_folder_with_masks_equals_predict_and_changes_no_input(png_folder, tmp_path, capsys):
    depth_dir, mask_dir, items = png_folder
    before = hashes(tmp_path)
    rc = main(["fill", str(depth_dir), "--holes", str(mask_dir), "-m", "scanline", "--format", "both",
               "--out", str(tmp_path / "out"), "-q"])
    assert rc == 0
    assert "4 written, 0 skipped, 0 failed" in capsys.readouterr().err
    assert {k: v for k, v in hashes(tmp_path).items() if not k.startswith("out/")} == before
    scanline = make_method("scanline")
    for rel, depth, mask in items:
        want = expected(scanline, depth, mask)
        got_npy = np.load(tmp_path / "out" / rel.with_suffix(".npy"))
        np.testing.assert_array_equal(got_npy, want)  # bit-identical, measured pixels included
        np.testing.assert_array_equal(read_depth_png(tmp_path / "out" / rel), np.rint(want * 256.0) / 256)
        assert (got_npy[mask] > 0).all() and np.isfinite(got_npy).all()
        assert (got_npy[~mask & (depth == 0)] == 0).all()  # no measurement outside the holes stays 0


def test_npy_with_nan_is_filled_as_predict_fills_it_in_its_own_dtype(tmp_path):
    (tmp_path / "in").mkdir()
    depth = frames(1, (48, 80))[0].astype(np.float64)
    x = depth.copy()
    x[10:30, 20:50] = np.nan
    np.save(tmp_path / "in" / "a.npy", x)
    report = fill(tmp_path / "in", tmp_path / "out", method="scanline", format="npy", progress=False)
    assert report.ok and len(report.written) == 1
    got = np.load(tmp_path / "out" / "a.npy")
    assert got.dtype == np.float64
    measured = depth > 0
    measured[10:30, 20:50] = False
    np.testing.assert_array_equal(got[measured], x[measured])  # bit-identical float64
    np.testing.assert_array_equal(got, expected(make_method("scanline"), np.nan_to_num(x), np.isnan(x)))


@pytest.mark.parametrize("shape", [(480, 640), (376, 1408)])
def test_frames_of_other_sizes(tmp_path, shape):
    d = frames(1, shape)[0]
    write_depth_png(tmp_path / "in" / "f.png", d)
    box = (shape[1] // 3, shape[0] // 3, shape[1] // 2, shape[0] // 2)
    rc = main(["fill", str(tmp_path / "in"), "--box", ",".join(map(str, box)), "-m", "scanline",
               "--out", str(tmp_path / "out"), "-q"])
    assert rc == 0
    mask = np.zeros(shape, bool)
    mask[box[1]:box[3], box[0]:box[2]] = True
    got = read_depth_png(tmp_path / "out" / "f.png")
    assert got.shape == shape
    np.testing.assert_array_equal(got, np.rint(expected(make_method("scanline"), d, mask) * 256.0) / 256)


@pytest.mark.slow
def test_pretrained_fill_equals_pretrained_predict_on_one_small_frame(tmp_path):
    shape = (64, 128)
    d = frames(1, shape)[0]
    write_depth_png(tmp_path / "in" / "f.png", d)
    mask = box_mask(shape, 0)
    np.save(tmp_path / "mask.npy", mask)
    rc = main(["fill", str(tmp_path / "in" / "f.png"), "--holes", str(tmp_path / "mask.npy"), "--format", "npy",
               "--out", str(tmp_path / "out"), "-q"])  # the default method: pretrained
    assert rc == 0
    want = expected(make_method("pretrained"), read_depth_png(tmp_path / "in" / "f.png"), mask)
    np.testing.assert_array_equal(np.load(tmp_path / "out" / "f.npy"), want)


def test_a_resumed_run_skips_what_exists_and_overwrite_redoes_it(png_folder, tmp_path, capsys):
    depth_dir, mask_dir, items = png_folder
    args = ["fill", str(depth_dir), "--holes", str(mask_dir), "-m", "scanline", "--out", str(tmp_path / "out"), "-q"]
    assert main(args) == 0
    first = tmp_path / "out" / items[0][0]
    first.unlink()
    (tmp_path / "out" / items[1][0]).write_bytes(b"kept")  # an existing output is not read, only skipped
    capsys.readouterr()
    assert main(args) == 0
    assert "1 written, 3 skipped" in capsys.readouterr().err
    assert first.is_file() and (tmp_path / "out" / items[1][0]).read_bytes() == b"kept"
    assert main([*args, "--overwrite"]) == 0
    assert "4 written, 0 skipped" in capsys.readouterr().err
    assert read_depth_png(tmp_path / "out" / items[1][0]).shape == (64, 96)
    assert not [p for p in (tmp_path / "out").rglob(".*")]  # no temporary file left


def test_one_corrupt_png_is_one_line_the_rest_are_written_and_the_exit_status_is_1(png_folder, tmp_path, capsys):
    depth_dir, mask_dir, items = png_folder
    bad = depth_dir / items[2][0]
    bad.write_bytes(bad.read_bytes()[:60])  # truncated
    before = hashes(depth_dir)
    rc = main(["fill", str(depth_dir), "--holes", str(mask_dir), "-m", "scanline", "--out", str(tmp_path / "out"),
               "-q"])
    err = capsys.readouterr().err
    assert rc == 1
    lines = [line for line in err.splitlines() if str(bad) in line]
    assert len(lines) == 1 and "Traceback" not in err, err
    assert "3 written, 0 skipped, 1 failed" in err
    assert sorted(p.relative_to(tmp_path / "out") for p in (tmp_path / "out").rglob("*.png")) == sorted(
        rel for rel, _, _ in items if rel != items[2][0])
    assert hashes(depth_dir) == before


def test_on_error_stop_stops_at_the_first_bad_file(png_folder, tmp_path, capsys):
    depth_dir, mask_dir, items = png_folder
    (depth_dir / items[0][0]).write_bytes(b"not a png")
    rc = main(["fill", str(depth_dir), "--holes", str(mask_dir), "-m", "scanline", "--out", str(tmp_path / "out"),
               "-q", "--on-error", "stop", "--batch-size", "1"])
    assert rc == 1
    err = capsys.readouterr().err
    assert "0 written, 0 skipped, 1 failed" in err


@pytest.mark.parametrize("problem, args, message", [
    ("no holes", [], "nothing marks the pixels to fill"),
    ("mask size", ["--holes", "MASK"], "is 10x12, the depth map 96x64"),
])
def test_bad_inputs_are_named_with_what_to_do(tmp_path, capsys, problem, args, message):
    write_depth_png(tmp_path / "in" / "f.png", frames(1, (64, 96))[0])
    cv2.imwrite(str(tmp_path / "mask.png"), np.ones((12, 10), np.uint8))
    args = [str(tmp_path / "mask.png") if a == "MASK" else a for a in args]
    rc = main(["fill", str(tmp_path / "in"), *args, "-m", "scanline", "--out", str(tmp_path / "out"), "-q"])
    err = capsys.readouterr().err
    assert rc == 1 and message in err and str(tmp_path / "in" / "f.png") in err
    assert "--holes" in NO_HOLES and "--box" in NO_HOLES and "--missing" in NO_HOLES


def test_never_writes_into_an_input_folder(tmp_path, capsys):
    write_depth_png(tmp_path / "in" / "f.png", frames(1, (64, 96))[0])
    assert main(["fill", str(tmp_path / "in"), "--missing", "--out", str(tmp_path / "in" / "out"), "-q"]) == 1
    assert "lies inside the input folder" in capsys.readouterr().err
    assert main(["fill", str(tmp_path / "in" / "f.png"), "--missing", "--out", str(tmp_path / "in"), "-q"]) == 1
    assert "never writes there" in capsys.readouterr().err
    assert sorted(p.name for p in (tmp_path / "in").iterdir()) == ["f.png"]


def test_missing_densifies_and_boxes_add_up(tmp_path):
    d = frames(1, (64, 96))[0]
    write_depth_png(tmp_path / "in" / "f.png", d)
    report = fill([tmp_path / "in" / "f.png"], tmp_path / "out", method="scanline", missing=True,
                  boxes=[(0, 0, 10, 10)], progress=False, fill_all=True)
    assert report.ok
    got = read_depth_png(tmp_path / "out" / "f.png")
    assert (got > 0).all()
    keep = d > 0
    keep[:10, :10] = False
    np.testing.assert_array_equal(got[keep], read_depth_png(tmp_path / "in" / "f.png")[keep])


def test_help_shows_the_three_recipes(capsys):
    with pytest.raises(SystemExit):
        build_parser().parse_args(["fill", "--help"])
    out = capsys.readouterr().out
    assert "--holes masks/" in out and "--format npy" in out and "--calib" in out and "--points bin" in out


# -- LiDAR scans ------------------------------------------------------------------------------------------

@pytest.mark.kitti
def test_scan_to_depth_to_filled_depth_to_points_keeps_every_original_point(kitti_raw_root, tmp_path, capsys):
    day = kitti_raw_root / "2011_09_26"
    scan_dir = day / "2011_09_26_drive_0009_sync" / "velodyne_points" / "data"
    before = hashes(scan_dir)
    rc = main(["fill", str(scan_dir / "0000000005.bin"), "--calib", str(day), "--box", "400,150,600,250",
               "-m", "scanline", "--points", "both", "--format", "both", "--out", str(tmp_path / "out"), "-q"])
    assert rc == 0, capsys.readouterr().err
    assert hashes(scan_dir) == before
    calib = read_calibration(day)
    original = read_scan(scan_dir / "0000000005.bin")
    depth = project_scan(original, calib)
    filled = np.load(tmp_path / "out" / "0000000005.npy")
    mask = np.zeros(depth.shape, bool)
    mask[150:250, 400:600] = True
    np.testing.assert_array_equal(filled[~mask], depth[~mask])
    np.testing.assert_array_equal(read_depth_file(tmp_path / "out" / "0000000005.png"), np.rint(filled * 256) / 256)
    out = read_scan(tmp_path / "out" / "0000000005.bin")
    check_points_added(out, original, filled, mask, calib)
    ply = (tmp_path / "out" / "0000000005.ply").read_bytes()
    assert f"element vertex {len(out)}".encode() in ply


@pytest.mark.kitti
@pytest.mark.parametrize("layout", ["odometry", "kitti360"])
def test_scans_of_the_other_layouts_fill_at_their_image_size(kitti_raw_root, tmp_path, layout):
    if layout == "odometry":
        scans, calib, size = kitti_raw_root / "odometry/sequences/05/velodyne", ["--calib", str(
            kitti_raw_root / "odometry/sequences/05/calib.txt"), "--size", "1226x370"], (370, 1226)
    else:
        scans, calib, size = kitti_raw_root / "kitti360/2013_05_28_drive_0000_sync/velodyne_points/data", [
            "--calib", str(kitti_raw_root / "kitti360/calibration")], (376, 1408)
    assert main(["fill", str(scans), *calib, "--box", "300,100,500,200", "-m", "scanline",
                 "--out", str(tmp_path / "out"), "-q"]) == 0
    outs = sorted((tmp_path / "out").glob("*.png"))
    assert outs and all(read_depth_png(p).shape == size for p in outs)


@pytest.mark.kitti
def test_a_slice_scan_thinned_to_16_and_8_beams_fills_by_the_sparse_route(kitti_raw_root, tmp_path, capsys):
    """docs/fill.md's sparser sensor: a raw .bin with every 4th / 8th ring kept, filled by the default."""
    from inpaintenv.data import thin_points_by_rings, write_points_bin
    from inpaintenv.filling.view import sensor_view

    day = kitti_raw_root / "2011_09_26"
    scan = next(iter(sorted(day.glob("*_sync/velodyne_points/data/*.bin"))))
    (tmp_path / "in").mkdir()
    for keep_every in (4, 8):
        write_points_bin(tmp_path / "in" / f"r{keep_every}.bin", thin_points_by_rings(read_scan(scan), keep_every))
    assert main(["fill", str(tmp_path / "in"), "--calib", str(day), "--missing", "--out", str(tmp_path / "out"), "-q"]) == 0
    assert "pretrained filled 2 as sparse scans with kitti-sparse-v1" in capsys.readouterr().err
    calib = read_calibration(day)
    for keep_every in (4, 8):
        depth = project_scan(read_scan(tmp_path / "in" / f"r{keep_every}.bin"), calib)
        filled = read_depth_png(tmp_path / "out" / f"r{keep_every}.png")
        measured = depth > 0
        np.testing.assert_allclose(filled[measured], depth[measured], atol=1 / 256)
        assert (filled[sensor_view(depth)] > 0).all()


def test_a_scan_without_calibration_is_one_line_and_the_pngs_are_still_written(tmp_path, capsys):
    write_depth_png(tmp_path / "in" / "f.png", frames(1, (64, 96))[0])
    np.zeros((10, 4), np.float32).tofile(tmp_path / "in" / "s.bin")
    rc = main(["fill", str(tmp_path / "in"), "--missing", "-m", "scanline", "--out", str(tmp_path / "out"), "-q"])
    err = capsys.readouterr().err
    assert rc == 1 and "s.bin: a LiDAR scan needs its calibration: give --calib PATH" in err
    assert (tmp_path / "out" / "f.png").is_file()



def test_a_mistyped_calib_path_is_one_line_before_any_input_is_read(tmp_path, capsys):
    """Was one line per scan, after the depth files were filled."""
    write_depth_png(tmp_path / "in" / "f.png", frames(1, (64, 96))[0])
    for k in range(3):
        np.zeros((10, 4), np.float32).tofile(tmp_path / "in" / f"s{k}.bin")
    assert main(["fill", str(tmp_path / "in"), "--missing", "--calib", str(tmp_path / "nowhere"),
                 "--out", str(tmp_path / "out2"), "-m", "scanline", "-q"]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f"--calib {tmp_path / 'nowhere'}: no such calibration" in err, err
    assert not (tmp_path / "out2").exists()


def test_option_errors_come_before_any_file(tmp_path, capsys):
    write_depth_png(tmp_path / "in" / "f.png", frames(1, (64, 96))[0])
    assert main(["fill", str(tmp_path / "in"), "--holes", str(tmp_path / "none"), "-m", "scanline",
                 "--out", str(tmp_path / "out"), "-q"]) == 1
    assert "--holes" in capsys.readouterr().err and not (tmp_path / "out").exists()
    with pytest.raises(ValueError, match="--jobs applies to methods that take n_jobs"):
        fill(tmp_path / "in", tmp_path / "out", method=lambda x: np.nan_to_num(x, nan=1.0), missing=True, n_jobs=2)
    with pytest.raises(ValueError, match="a box x0,y0,x1,y1 needs 0 <= x0 < x1"):
        fill(tmp_path / "in", tmp_path / "out", method="scanline", boxes=[(5, 5, 5, 9)])
    with pytest.raises(SystemExit):
        build_parser().parse_args(["fill", "x", "--out", "y", "--box", "1,2,3"])
    assert "a box is x0,y0,x1,y1" in capsys.readouterr().err


def test_a_callable_method_and_jobs_for_a_classical_one(tmp_path):
    write_depth_png(tmp_path / "in" / "f.png", frames(1, (64, 96))[0])
    report = fill(tmp_path / "in", tmp_path / "out", method=lambda x: np.nan_to_num(x, nan=7.0),
                  boxes=[(0, 0, 8, 8)], progress=False)
    assert report.ok and (read_depth_png(tmp_path / "out" / "f.png")[:8, :8] == 7.0).all()
    assert fill(tmp_path / "in", tmp_path / "out2", method="scanline", n_jobs=2, boxes=[(0, 0, 8, 8)],
                progress=False).ok


def test_progress_outside_a_terminal_is_plain_lines(tmp_path, capsys):
    for k, d in enumerate(frames(2, (64, 96))):
        write_depth_png(tmp_path / "in" / f"{k}.png", d)
    assert main(["fill", str(tmp_path / "in"), "--missing", "-m", "scanline", "--out", str(tmp_path / "out")]) == 0
    err = capsys.readouterr().err
    assert "s/frame from its first batch" in err and "fill: 2 frames in" in err and "\r" not in err


def test_fill_depth_in_memory_and_what_a_method_leaves_at_zero(tmp_path, capsys):
    from inpaintenv.filling import fill_depth

    d = frames(1, (64, 96))[0]
    mask = box_mask((64, 96), 0)
    before = d.copy()
    np.testing.assert_array_equal(fill_depth("scanline", d, mask), expected(make_method("scanline"), d, mask))
    np.testing.assert_array_equal(d, before)  # the caller's array is not filled in place
    write_depth_png(tmp_path / "in" / "f.png", d)
    tiny = fill(tmp_path / "in", tmp_path / "tiny", method=lambda x: np.nan_to_num(x, nan=0.001),
                boxes=[(0, 0, 8, 8)], progress=False)
    assert tiny.ok and (read_depth_png(tmp_path / "tiny" / "f.png")[:8, :8] == 1 / 256).all()  # not 0 = no data
    zero = fill(tmp_path / "in", tmp_path / "zero", method=lambda x: np.nan_to_num(x, nan=0.0),
                boxes=[(0, 0, 8, 8)], progress=False)
    assert not zero.ok and "left 64 of the 64 pixels to fill at 0 m" in zero.failed[0][1]
    assert not (tmp_path / "zero" / "f.png").exists()


def test_ctrl_c_keeps_complete_files_and_the_rerun_resumes(png_folder, tmp_path, capsys, monkeypatch):
    from estimators.classical import ScanlineInpainter

    depth_dir, mask_dir, items = png_folder
    original, calls = ScanlineInpainter.predict, [0]

    def predict(self, X):
        calls[0] += 1
        if calls[0] > 1:
            raise KeyboardInterrupt
        return original(self, X)

    monkeypatch.setattr(ScanlineInpainter, "predict", predict)
    args = ["fill", str(depth_dir), "--holes", str(mask_dir), "-m", "scanline", "--batch-size", "1",
            "--out", str(tmp_path / "out"), "-q"]
    assert main(args) == 130
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"inpaintenv fill: interrupted; the files written so far are kept in {tmp_path / 'out'} (each "
                   "complete); rerun the same command to go on (existing outputs are skipped)"]
    written = sorted(p for p in (tmp_path / "out").rglob("*") if p.is_file() and p.name not in (LEDGER, LOCK_FILE))
    assert [p.relative_to(tmp_path / "out") for p in written] == [items[0][0]]  # no temporary file left
    monkeypatch.setattr(ScanlineInpainter, "predict", original)
    assert main(args) == 0
    assert "3 written, 1 skipped" in capsys.readouterr().err


def test_a_mask_inside_the_input_folder_is_not_an_input(tmp_path, capsys):
    d = frames(1, (64, 96))[0]
    write_depth_png(tmp_path / "in" / "f.png", d)
    cv2.imwrite(str(tmp_path / "in" / "mask.png"), box_mask((64, 96), 0).astype(np.uint8) * 255)
    rc = main(["fill", str(tmp_path / "in"), "--holes", str(tmp_path / "in" / "mask.png"), "-m", "scanline",
               "--out", str(tmp_path / "out"), "-q"])
    assert rc == 0 and "1 written, 0 skipped, 0 failed" in capsys.readouterr().err
    assert names(tmp_path / "out") == ["f.png"]


def test_npz_input_and_points_without_scans(tmp_path, capsys):
    x = frames(1, (48, 80))[0]
    x[5:15, 10:40] = np.nan
    np.savez(tmp_path / "f.npz", depth=x)
    assert main(["fill", str(tmp_path / "f.npz"), "-m", "scanline", "--format", "both",
                 "--out", str(tmp_path / "out"), "-q"]) == 0
    assert names(tmp_path / "out") == ["f.npy", "f.png"]
    assert not np.isnan(np.load(tmp_path / "out" / "f.npy")).any()
    assert main(["fill", str(tmp_path / "f.npz"), "--points", "bin", "--out", str(tmp_path / "o2"), "-q"]) == 1
    assert "applies to .bin LiDAR scans" in capsys.readouterr().err
