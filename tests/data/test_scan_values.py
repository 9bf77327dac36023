"""What a scan point, a calibration and a depth frame may be (inpaintenv.values), through the readers that use them.

Far points (beyond the 16-bit PNG's 255.996 m) are left out and counted, never stored as 255.996 m;
a scan none of whose points lands in the image, a left-handed projection, a 16-bit PNG of plain
metres and a scan given the calibration of another rig are each one clear error. The real scans
of ``kitti-raw`` check the rig rule and the measured shares behind it.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from inpaintenv.cli import main
from inpaintenv.conventions import DEPTH_LIMIT
from inpaintenv.data import (
    Calibration,
    CalibrationError,
    DepthFormatError,
    ScanFormatError,
    project_points,
    project_scan,
    read_calibration,
    read_depth_file,
    read_scan,
    write_points_bin,
)
from inpaintenv.data.io import write_png
from inpaintenv.data.projection import drop_far_points
from inpaintenv.filling import fill
from inpaintenv.values.calibration import recording_day, rig_of_scan
from inpaintenv.values.points import MAX_FAR_SHARE

SHAPE = (48, 120)
#: A camera looking along the LiDAR's x axis (LiDAR: x forward, y left, z up), 120 x 48 pixels.
CAMERA = np.array([[60.0, 0, 60, 0], [0, 60, 24, 0], [0, 0, 1, 0]]) @ np.array(
    [[0, -1, 0, 0], [0, 0, -1, 0], [1, 0, 0, 0], [0, 0, 0, 1]], dtype=float)
RAW_DAY = "2011_09_26"
K360_SCAN = Path("kitti360") / "2013_05_28_drive_0000_sync" / "velodyne_points" / "data" / "0000000100.bin"


def calibration() -> Calibration:
    return Calibration(CAMERA, (SHAPE[1], SHAPE[0]), "odometry")


def wall() -> np.ndarray:
    """A 16-beam scan of a wall 8-12 m ahead (2,000 points, all in front of the camera)."""
    az, el = np.meshgrid(np.radians(np.arange(-50, 50, 0.8)), np.radians(np.linspace(3, -15, 16)))
    x = 10 + 2 * np.sin(3 * az)
    return np.stack([x, x * np.tan(az), x * np.tan(el) / np.cos(az), np.full_like(x, 0.5)], -1).reshape(-1, 4) \
        .astype(np.float32)


def run(inputs, out, **kw):
    lines: list[str] = []
    report = fill(inputs, out, method="nearest", missing=True, progress=False, log=lines.append, **kw)
    return report, lines


# -- a point beyond the PNG limit ---------------------------------------------------------------------------

def test_a_far_point_is_left_out_counted_and_not_written_as_points(tmp_path):
    scan = np.vstack([wall(), [[1e30, 0, 0, 0.5]]]).astype(np.float32)  # one return straight ahead at 1e30 m
    write_points_bin(tmp_path / "s.bin", scan)
    report, lines = run([tmp_path / "s.bin"], tmp_path / "out", calibration=calibration(), points="bin",
                        format="npy")
    assert report.ok, report.failed
    filled = np.load(tmp_path / "out" / "s.npy")
    assert filled.max() < 13  # the wall; nothing stored or spread at 255.996 m
    assert not np.isin(1e30, read_scan(tmp_path / "out" / "s.bin")[:, 0])
    assert np.array_equal(read_scan(tmp_path / "out" / "s.bin")[:len(scan) - 1], scan[:-1])
    assert lines == [f"{tmp_path / 's.bin'}: 1 point farther than 255.996 m (the most a 16-bit PNG holds) left out, "
                     "as points behind the camera are"]


def test_project_scan_refuses_a_far_point_instead_of_storing_the_limit():
    scan = np.vstack([wall(), [[300.0, 0, 0, 0]]]).astype(np.float32)
    with pytest.raises(ScanFormatError, match=r"points: 1 point is farther than 255\.996 m .*projection\.drop_far_points"):
        project_scan(scan, calibration())
    kept, n_far = drop_far_points(scan, calibration())
    assert n_far == 1 and len(kept) == len(scan) - 1
    assert project_scan(kept, calibration()).max() < 13


def test_a_scan_mostly_beyond_the_limit_is_refused_as_not_metres(tmp_path):
    scan = wall()
    scan[:, :3] *= 30  # 240-360 m: most of the wall beyond the limit
    write_points_bin(tmp_path / "s.bin", scan)
    report, _ = run([tmp_path / "s.bin"], tmp_path / "out", calibration=calibration())
    (_, why), = report.failed
    assert "farther than 255.996 m" in why and "unit mistake" in why
    assert not (tmp_path / "out" / "s.png").exists()


def test_the_far_share_bound_is_exact():
    calib = calibration()
    scan = wall()
    n_far = int(MAX_FAR_SHARE * len(scan))  # the most that may be left out
    far = np.tile([[400.0, 0, 0, 0]], (n_far, 1)).astype(np.float32)
    assert drop_far_points(np.vstack([scan, far]), calib)[1] == n_far
    with pytest.raises(ScanFormatError, match="unit mistake"):
        drop_far_points(np.vstack([scan, far, far[:1] + 1, far[:20]]), calib)


# -- no point lands in the image ----------------------------------------------------------------------------

def test_a_scan_all_behind_the_camera_is_one_error_not_an_empty_map(tmp_path, capsys):
    scan = wall()
    scan[:, 0] *= -1  # the wall behind the car
    write_points_bin(tmp_path / "s.bin", scan)
    calib = tmp_path / "calib.txt"
    calib.write_text("".join(f"P{i}: 60 0 60 0 0 60 24 0 0 0 1 0\n" for i in range(4)) + "Tr: 0 -1 0 0 0 0 -1 0 1 0 0 0\n")
    status = main(["fill", str(tmp_path / "s.bin"), "--calib", str(calib), "--size", "120x48", "--out",
                   str(tmp_path / "out"), "-m", "nearest", "--missing", "-q"])
    err = capsys.readouterr().err
    assert status == 1 and "no point of the scan lands in the 120x48 image (2000 of its 2000 points behind the camera or within 0.1 m" in err
    assert not (tmp_path / "out" / "s.png").exists()


def test_points_beside_the_image_are_counted_in_the_error():
    scan = wall()
    scan[:, 1] += 500  # far to the left
    with pytest.raises(CalibrationError, match=r"0 of its 2000 points behind the camera or within 0.1 m of it, 2000 beside the image"):
        project_scan(scan, calibration())


# -- a projection that is not right-handed ------------------------------------------------------------------

def test_a_negated_depth_row_is_refused():
    flipped = CAMERA.copy()
    flipped[2] *= -1  # points behind the camera would land in the image
    with pytest.raises(CalibrationError, match=r"not right-handed .* depth row"):
        Calibration(flipped, (SHAPE[1], SHAPE[0]), "odometry")


@pytest.mark.parametrize("p2", ["60 0 60 0 0 60 24 0 0 0 -1 0", "-60 0 60 0 0 60 24 0 0 0 1 0"])
def test_a_left_handed_calibration_file_is_refused_with_its_name(tmp_path, p2):
    calib = tmp_path / "calib.txt"
    calib.write_text(f"P2: {p2}\nTr: 0 -1 0 0 0 0 -1 0 1 0 0 0\n")
    with pytest.raises(CalibrationError, match=rf"{calib}: the projection matrix is not right-handed"):
        read_calibration(calib, size=(120, 48))


def test_a_camera_turned_backwards_is_a_real_camera():
    k = np.array([[60.0, 0, 60], [0, 60, 24], [0, 0, 1]])
    turned = np.diag([-1.0, 1, -1]) @ np.array([[0, -1.0, 0, 0], [0, 0, -1, 0], [1, 0, 0, 0]])  # 180 deg about y
    scan = wall()
    scan[:, 0] *= -1  # the wall behind the car, in the rear camera's view
    assert (project_scan(scan, Calibration(k @ turned, (SHAPE[1], SHAPE[0]), "odometry")) > 0).any()


# -- a 16-bit PNG of plain metres, an array normalised to 0..1 ----------------------------------------------

def test_a_png_of_plain_metres_is_refused_saying_what_it_looks_like(tmp_path, capsys):
    metres = np.where(np.random.default_rng(0).random((32, 64)) < 0.3, np.linspace(5, 80, 64), 0).astype(np.uint16)
    write_png(tmp_path / "a.png", metres)
    status = main(["fill", str(tmp_path / "a.png"), "--out", str(tmp_path / "out"), "-m", "nearest", "--missing",
                   "-q"])
    err = capsys.readouterr().err
    assert status == 1 and "every measured pixel is under 1 m (the largest 0.3125 m, stored as 80)" in err
    assert "16-bit PNG of plain metres" in err and "80 m as 20480" in err
    assert not (tmp_path / "out" / "a.png").exists()


def test_a_normalised_array_is_refused_and_a_metre_frame_is_read(tmp_path):
    depth = np.where(np.random.default_rng(0).random((32, 64)) < 0.3, 0.9, 0.0)
    np.save(tmp_path / "a.npy", depth)
    with pytest.raises(DepthFormatError, match="every measured depth is under 1 m"):
        read_depth_file(tmp_path / "a.npy")
    depth[0, 0] = 1.0  # one metre somewhere: a plausible frame
    np.save(tmp_path / "b.npy", depth)
    assert read_depth_file(tmp_path / "b.npy")[0, 0] == 1.0
    np.save(tmp_path / "c.npy", np.zeros((32, 64)))  # nothing measured: no scale to judge
    assert not read_depth_file(tmp_path / "c.npy").any()


# -- a scan and the calibration of another rig --------------------------------------------------------------

@pytest.mark.parametrize(("path", "rig"), [
    ("x/2013_05_28_drive_0000_sync/velodyne_points/data/0000000100.bin", "kitti360"),
    ("data_3d_raw/2013_05_28_drive_0003_sync/velodyne_points/data/0000000000.bin", "kitti360"),
    ("2011_09_26/2011_09_26_drive_0001_sync/velodyne_points/data/0000000005.bin", "kitti"),
    ("odometry/sequences/05/velodyne/000002.bin", "kitti"),
    ("scans/s.bin", None),
])
def test_the_rig_of_a_scan_comes_from_its_folders(path, rig):
    assert rig_of_scan(Path(path)) == rig


def test_a_kitti360_scan_with_a_raw_calibration_is_refused(tmp_path):
    scan = tmp_path / "2013_05_28_drive_0000_sync" / "velodyne_points" / "data" / "0000000000.bin"
    scan.parent.mkdir(parents=True)
    write_points_bin(scan, wall())
    report, _ = run([scan], tmp_path / "out", calibration=Calibration(CAMERA, (120, 48), "raw"))
    (_, why), = report.failed
    assert "is a KITTI-360 scan" in why and "a KITTI raw one, of the KITTI raw/odometry rig" in why
    report, _ = run([scan], tmp_path / "out", calibration=Calibration(CAMERA, (120, 48), "kitti360"))
    assert report.ok, report.failed


@pytest.mark.parametrize(("path", "day"), [
    ("2011_09_26/2011_09_26_drive_0001_sync/velodyne_points/data/0000000005.bin", "2011_09_26"),
    ("kitti-raw/2011_09_30", "2011_09_30"),
    ("odometry/sequences/05/velodyne/000002.bin", "2011_09_30"),
    ("odometry/sequences/00/calib.txt", "2011_10_03"),
    ("odometry/sequences/11/calib.txt", None),  # a test sequence: no raw day published
    ("2013_05_28_drive_0000_sync/velodyne_points/data/0000000000.bin", None),
    ("scans/s.bin", None),
])
def test_the_recording_day_of_a_path(path, day):
    assert recording_day(Path(path)) == day


def test_a_scan_with_another_days_raw_calibration_is_refused(tmp_path):
    scan = tmp_path / "2011_09_30_drive_0018_sync" / "velodyne_points" / "data" / "0000000000.bin"
    scan.parent.mkdir(parents=True)
    write_points_bin(scan, wall())
    report, _ = run([scan], tmp_path / "out", calibration=_raw_folder(tmp_path / "2011_09_26"))
    (_, why), = report.failed
    assert "was recorded on 2011_09_30" in why and "is of 2011_09_26" in why
    report, _ = run([scan], tmp_path / "out", calibration=_raw_folder(tmp_path / "2011_09_30"))
    assert report.ok, report.failed


@pytest.mark.kitti
def test_real_scans_with_the_other_rigs_calibration_are_refused(kitti_raw_root, tmp_path):
    raw_scan = kitti_raw_root / RAW_DAY / f"{RAW_DAY}_drive_0001_sync" / "velodyne_points" / "data" / "0000000005.bin"
    for scan, calib in ((kitti_raw_root / K360_SCAN, kitti_raw_root / RAW_DAY),
                        (raw_scan, kitti_raw_root / "kitti360" / "calibration")):
        report, _ = run([scan], tmp_path / "out", calibration=calib)
        (_, why), = report.failed
        assert "would project plausible-looking maps with the wrong geometry" in why


@pytest.mark.kitti
def test_another_days_calibration_moves_real_points_and_is_refused(kitti_raw_root, tmp_path):
    scan = kitti_raw_root / "odometry" / "sequences" / "05" / "velodyne" / "000002.bin"  # 2011_09_30 drive 0018
    own = read_calibration(kitti_raw_root / "odometry" / "sequences" / "05" / "calib.txt", size=(1226, 370))
    other = read_calibration(kitti_raw_root / RAW_DAY)
    u1, v1, z1 = project_points(read_scan(scan), own)
    u2, v2, z2 = project_points(read_scan(scan), other)
    seen = (z1 > 1) & (u1 >= 0) & (u1 < 1226) & (v1 >= 0) & (v1 < 370)
    # docs/fill.md: 2011_09_26's calibration moves these points by 10 px (median)
    assert np.median(np.hypot(u1 - u2, v1 - v2)[seen]) == pytest.approx(10.5, abs=0.5)
    report, _ = run([scan], tmp_path / "out", calibration=kitti_raw_root / RAW_DAY)
    (_, why), = report.failed
    assert "was recorded on 2011_09_30" in why and "is of 2011_09_26" in why


@pytest.mark.kitti
def test_the_share_of_points_in_the_image_does_not_tell_the_rigs_apart(kitti_raw_root):
    """Why the rig comes from the folders: the measurement behind the rule, as a check that it still holds."""
    def share(scan: Path, calib: Path) -> float:
        c = read_calibration(calib)
        u, v, z = project_points(read_scan(scan), c)
        w, h = c.image_size()
        with np.errstate(invalid="ignore"):
            return float(np.mean((z > 0.1) & (np.rint(u) >= 0) & (np.rint(u) < w) & (np.rint(v) >= 0)
                                 & (np.rint(v) < h)))

    raw = kitti_raw_root / RAW_DAY / f"{RAW_DAY}_drive_0009_sync" / "velodyne_points" / "data" / "0000000005.bin"
    k360 = kitti_raw_root / K360_SCAN
    # 16 % of the raw scan in its image, 17 % of the KITTI-360 scan in the same image, 24 % in its own
    assert share(raw, kitti_raw_root / RAW_DAY) == pytest.approx(0.16, abs=0.005)
    assert share(k360, kitti_raw_root / RAW_DAY) == pytest.approx(0.17, abs=0.005)
    assert share(k360, kitti_raw_root / "kitti360" / "calibration") == pytest.approx(0.24, abs=0.005)


@pytest.mark.kitti
def test_real_scans_keep_every_point_and_a_decimetre_scan_is_refused(kitti_raw_root, tmp_path):
    calib = read_calibration(kitti_raw_root / RAW_DAY)
    scan = read_scan(kitti_raw_root / RAW_DAY / f"{RAW_DAY}_drive_0001_sync" / "velodyne_points" / "data"
                     / "0000000005.bin")
    assert drop_far_points(scan, calib)[1] == 0  # a HDL-64E's returns end near 120 m
    scaled = scan.copy()
    scaled[:, :3] *= 10
    z = project_points(scaled, calib)[2]
    assert np.mean(z[z > 0.1] > DEPTH_LIMIT) == pytest.approx(0.06, abs=0.005)  # 6 % beyond the limit
    folder = tmp_path / f"{RAW_DAY}_drive_0001_sync"
    folder.mkdir()
    write_points_bin(folder / "s.bin", scaled)
    shutil.copytree(kitti_raw_root / RAW_DAY, tmp_path / "calib", ignore=shutil.ignore_patterns("*_sync"))
    report, _ = run([folder / "s.bin"], tmp_path / "out", calibration=tmp_path / "calib")
    (_, why), = report.failed
    assert "unit mistake" in why and f"{DEPTH_LIMIT:.3f}" in why


# -- calibration files: numbers beyond a float, fractional sizes, two layouts in one folder -------------------

def _raw_folder(folder: Path, size: str = "120 48") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "calib_cam_to_cam.txt").write_text(
        f"S_rect_02: {size}\nR_rect_00: 1 0 0 0 1 0 0 0 1\nP_rect_02: 60 0 60 0 0 60 24 0 0 0 1 0\n")
    (folder / "calib_velo_to_cam.txt").write_text("R: 0 -1 0 0 0 -1 1 0 0\nT: 0 0 0\n")
    return folder


def test_a_number_beyond_any_float_is_named_not_miscounted(tmp_path):
    calib = tmp_path / "calib.txt"
    calib.write_text("P2: 1e400 0 60 0 0 60 24 0 0 0 1 0\nTr: 0 -1 0 0 0 0 -1 0 1 0 0 0\n")
    with pytest.raises(CalibrationError, match=rf"{calib} line 1: P2 holds a number beyond any float"):
        read_calibration(calib, size=(120, 48))


def test_an_image_size_of_fractional_pixels_is_refused(tmp_path):
    np.testing.assert_array_equal(read_calibration(_raw_folder(tmp_path / "a", "1.20e+02 4.8e1")).size, (120, 48))
    with pytest.raises(CalibrationError, match=r"S_rect_02 is 120\.4 x 48\.6; an image size is whole pixels"):
        read_calibration(_raw_folder(tmp_path / "b", "120.4 48.6"))


def test_a_folder_holding_two_layouts_is_refused_until_a_file_is_named(tmp_path):
    folder = _raw_folder(tmp_path / "both")
    (folder / "perspective.txt").write_text("S_rect_00: 120 48\nR_rect_00: 1 0 0 0 1 0 0 0 1\n"
                                            "P_rect_00: 60 0 60 0 0 60 24 0 0 0 1 0\n")
    (folder / "calib_cam_to_velo.txt").write_text("0 0 1 0 -1 0 0 0 0 -1 0 0\n")
    with pytest.raises(CalibrationError, match="holds both a KITTI raw .* and a KITTI-360"):
        read_calibration(folder)
    assert read_calibration(folder / "perspective.txt").kind == "kitti360"
    assert read_calibration(folder / "calib_velo_to_cam.txt").kind == "raw"


@pytest.mark.parametrize(("key", "value", "says"), [
    ("R", "0 -1000 0 0 0 -1000 1000 0 0", "is not a rotation"),  # millimetres typed into a rotation
    ("R", "0 -1 0 0 0 -1 1 0 0.1", "is not a rotation"),
    ("R", "0 1 0 0 0 -1 1 0 0", "is a reflection"),  # right-handed overall only with another negation
])
def test_a_calibration_files_rotation_must_be_one(tmp_path, key, value, says):
    folder = _raw_folder(tmp_path / "raw")
    (folder / "calib_velo_to_cam.txt").write_text(f"{key}: {value}\nT: 0 0 0\n")
    with pytest.raises(CalibrationError, match=rf"calib_velo_to_cam\.txt: R {says}"):
        read_calibration(folder)


@pytest.mark.parametrize("matrix", ["abc", np.full((3, 4), None), np.eye(3, 4) * (1 + 1j)])
def test_a_projection_that_is_not_real_numbers_is_one_calibration_error(matrix):
    with pytest.raises(CalibrationError, match="real numbers|NaN or infinite"):
        Calibration(matrix, (120, 48), "odometry")
