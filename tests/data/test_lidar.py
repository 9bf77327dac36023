"""LiDAR scans, the three calibration layouts, projection to a depth map and back (inpaintenv.data.calibration
and inpaintenv.data.projection).

The real scans of ``kitti-raw`` (found by the ``kitti_raw_root`` fixture: ``$INPAINTENV_KITTI_RAW_ROOT``, else
``kitti-raw`` beside the KITTI slice) are checked against what their README says each must equal.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from inpaintenv.data import (
    Calibration,
    CalibrationError,
    ScanFormatError,
    depth_to_points,
    project_points,
    project_scan,
    read_calibration,
    read_depth_png,
    read_scan,
    write_points_bin,
    write_points_ply,
)
from inpaintenv.data.calibration import parse_size

RAW_DAY = "2011_09_26"
ODOMETRY = "odometry/sequences/05"
KITTI360 = "kitti360/calibration"


def raw_scan(root: Path, drive: str, frame: int) -> Path:
    return root / RAW_DAY / f"{RAW_DAY}_drive_{drive}_sync" / "velodyne_points" / "data" / f"{frame:010d}.bin"


def velodyne_raw(kitti_root: Path, drive: str, frame: int) -> np.ndarray:
    return read_depth_png(kitti_root / "train" / f"{drive}_sync" / "proj_depth" / "velodyne_raw" / "image_02"
                          / f"{frame:010d}.png")


# -- the real scans against the maps their README names ---------------------------------------------------------

@pytest.mark.kitti
@pytest.mark.parametrize("frame", [5, 6, 7])
def test_raw_scan_projects_to_its_velodyne_raw_map(kitti_raw_root, kitti_root, frame):
    calib = read_calibration(kitti_raw_root / RAW_DAY)
    assert calib.kind == "raw" and calib.size == (1242, 375)
    depth = project_scan(read_scan(raw_scan(kitti_raw_root, "0009", frame)), calib)
    np.testing.assert_array_equal(depth, velodyne_raw(kitti_root, "2011_09_26_drive_9009", frame))


@pytest.mark.kitti
@pytest.mark.parametrize("scan", [2, 3, 4])
def test_odometry_scan_projects_to_its_velodyne_raw_map(kitti_raw_root, kitti_root, scan):
    calib = read_calibration(kitti_raw_root / ODOMETRY / "calib.txt", size=(1226, 370))
    assert calib.kind == "odometry"
    depth = project_scan(read_scan(kitti_raw_root / ODOMETRY / "velodyne" / f"{scan:06d}.bin"), calib)
    np.testing.assert_array_equal(depth, velodyne_raw(kitti_root, "2011_09_30_drive_9018", scan))


@pytest.mark.kitti
def test_drive_0001_lies_within_the_stated_tolerance_of_kittis_official_map(kitti_raw_root, kitti_root):
    # README: 19,154 official pixels against 19,137 projected; official pixels a median 0.8 px (90 % within
    # 1.9 px) from the projected points, median depth difference 5 cm. Thresholds just above those numbers.
    from scipy.spatial import cKDTree

    calib = read_calibration(kitti_raw_root / RAW_DAY)
    points = read_scan(raw_scan(kitti_raw_root, "0001", 5))
    official = velodyne_raw(kitti_root, "2011_09_26_drive_0001", 5)
    projected = project_scan(points, calib)
    n_official, n_projected = int((official > 0).sum()), int((projected > 0).sum())
    assert abs(n_projected - n_official) <= 0.005 * n_official  # 17 of 19,154 (0.09 %)
    u, v, z = project_points(points, calib)
    front = z > 0.1
    rows, cols = np.nonzero(official)
    dist, nearest = cKDTree(np.c_[u[front], v[front]]).query(np.c_[cols, rows])
    assert np.median(dist) <= 1.0 and np.percentile(dist, 90) <= 2.0
    assert np.median(np.abs(z[front][nearest] - official[rows, cols])) <= 0.08
    assert not np.array_equal(projected, official)  # KITTI's tool does more than the plain projection


@pytest.mark.kitti
def test_kitti360_scan_covers_about_five_percent_of_its_image(kitti_raw_root):
    calib = read_calibration(kitti_raw_root / KITTI360)
    assert calib.kind == "kitti360" and calib.size == (1408, 376) and calib.camera == 0
    depth = project_scan(read_scan(kitti_raw_root / "kitti360" / "2013_05_28_drive_0000_sync" / "velodyne_points"
                                   / "data" / "0000000100.bin"), calib)
    assert depth.shape == (376, 1408)
    assert 0.04 < (depth > 0).mean() < 0.06  # README: about 5 %
    assert 10.0 < np.median(depth[depth > 0]) < 12.0  # README: median depth 11 m


@pytest.mark.kitti
@pytest.mark.parametrize("layout", ["raw", "odometry", "kitti360"])
def test_back_projected_measured_pixels_return_to_their_points_within_a_pixel(kitti_raw_root, layout):
    calib, scan = {
        "raw": (lambda: read_calibration(kitti_raw_root / RAW_DAY), raw_scan(kitti_raw_root, "0009", 5)),
        "odometry": (lambda: read_calibration(kitti_raw_root / ODOMETRY, size=(1226, 370)),
                     kitti_raw_root / ODOMETRY / "velodyne" / "000002.bin"),
        "kitti360": (lambda: read_calibration(kitti_raw_root / "kitti360"),
                     kitti_raw_root / "kitti360" / "2013_05_28_drive_0000_sync" / "velodyne_points" / "data"
                     / "0000000100.bin"),
    }[layout]
    calib = calib()
    points = read_scan(scan)
    depth, index = project_scan(points, calib, return_index=True)
    back = depth_to_points(depth, calib)
    winners = index[depth > 0]  # row-major, as depth_to_points orders its points
    assert len(back) == len(winners) > 10_000
    ub, vb, zb = project_points(back, calib)
    up, vp, zp = project_points(points[winners], calib)
    assert np.hypot(ub - up, vb - vp).max() <= 0.75  # half a pixel each way: within a pixel
    assert np.abs(zb - zp).max() <= 0.5 / 256 + 1e-6  # the depth rounded to the PNG step, and no more
    rows, cols = np.nonzero(depth)
    np.testing.assert_array_equal(np.rint(ub), cols)
    np.testing.assert_array_equal(np.rint(vb), rows)


@pytest.mark.kitti
def test_calibration_is_found_from_where_users_point(kitti_raw_root):
    day = kitti_raw_root / RAW_DAY
    want = read_calibration(day).matrix
    for where in (day / "calib_velo_to_cam.txt", day / f"{RAW_DAY}_drive_0001_sync"):
        np.testing.assert_array_equal(read_calibration(where).matrix, want)
    assert read_calibration(kitti_raw_root / ODOMETRY, size=(1226, 370)).kind == "odometry"
    assert read_calibration(day, camera=3).camera == 3


# -- without the real files ---------------------------------------------------------------------------------

def toy_calibration(size=(40, 30)) -> Calibration:
    """A camera looking along the LiDAR's x axis (KITTI's axes: x forward, y left, z up)."""
    k = np.array([[20.0, 0, 20], [0, 20.0, 15], [0, 0, 1]])
    velo_to_cam = np.array([[0, -1.0, 0, 0], [0, 0, -1.0, 0], [1.0, 0, 0, 0]])
    return Calibration(k @ velo_to_cam, size, "raw")


def test_nearest_point_wins_a_pixel_and_near_or_outside_points_are_dropped():
    calib = toy_calibration()
    points = np.array([[10, 0, 0, 0.5], [5, 0, 0, 0.1], [0.05, 0, 0, 0], [10, 100, 0, 0], [-3, 0, 0, 0]], np.float32)
    depth, index = project_scan(points, calib, return_index=True)
    assert depth.shape == (30, 40) and (depth > 0).sum() == 1
    assert depth[15, 20] == 5.0 and index[15, 20] == 1 and (index >= 0).sum() == 1


def test_projection_rounds_depth_to_the_png_step_unless_asked_not_to():
    calib = toy_calibration()
    points = np.array([[10.001, 0, 0, 0]], np.float32)
    assert project_scan(points, calib)[15, 20] == np.float32(round(10.001 * 256) / 256)
    assert project_scan(points, calib, quantize=False)[15, 20] == np.float32(np.float64(np.float32(10.001)))


def test_depth_to_points_inverts_the_projection_of_pixel_centres():
    calib = toy_calibration()
    depth = np.zeros((30, 40), np.float32)
    depth[3, 7], depth[20, 33] = 4.0, 12.5
    back = depth_to_points(depth, calib)
    u, v, z = project_points(back, calib)
    np.testing.assert_allclose(np.c_[u, v, z], [[7, 3, 4.0], [33, 20, 12.5]], atol=1e-9)
    assert depth_to_points(depth, calib, mask=np.eye(30, 40, dtype=bool)).shape == (0, 3)


def test_scan_files_round_trip_and_ply_is_readable(tmp_path):
    points = np.random.default_rng(0).normal(size=(7, 4)).astype(np.float32)
    write_points_bin(tmp_path / "a.bin", points)
    np.testing.assert_array_equal(read_scan(tmp_path / "a.bin"), points)
    write_points_bin(tmp_path / "b.bin", points[:, :3])
    assert (read_scan(tmp_path / "b.bin")[:, 3] == 0).all()
    write_points_ply(tmp_path / "a.ply", points)
    raw = (tmp_path / "a.ply").read_bytes()
    header, _, body = raw.partition(b"end_header\n")
    assert b"element vertex 7" in header and b"binary_little_endian" in header
    np.testing.assert_array_equal(np.frombuffer(body, "<f4").reshape(-1, 4), points)


def test_a_file_that_is_not_a_scan_is_named(tmp_path):
    bad = tmp_path / "scan.bin"
    bad.write_bytes(b"\x00" * 18)
    with pytest.raises(ScanFormatError, match=r"scan\.bin is not a KITTI LiDAR scan: 18 bytes"):
        read_scan(bad)
    with pytest.raises(FileNotFoundError, match="scan not found"):
        read_scan(tmp_path / "none.bin")


def write_raw_day(folder: Path, drop: str | None = None) -> Path:
    folder.mkdir()
    cam = {"calib_time": "09-Jan-2012 13:57:47", "S_rect_02": "1.242000e+03 3.750000e+02",
           "R_rect_00": " ".join(map(str, np.eye(3).ravel())),
           "P_rect_02": "721.5 0 609.5 44.8 0 721.5 172.8 0.2 0 0 1 0.0027"}
    velo = {"R": "0 -1 0 0 0 -1 1 0 0", "T": "0 0 0"}
    for name, values in (("calib_cam_to_cam.txt", cam), ("calib_velo_to_cam.txt", velo)):
        (folder / name).write_text("".join(f"{k}: {v}\n" for k, v in values.items() if k != drop))
    return folder


def test_calibration_errors_name_the_file_and_the_key(tmp_path):
    assert read_calibration(write_raw_day(tmp_path / "ok")).size == (1242, 375)
    with pytest.raises(CalibrationError, match=r"calib_cam_to_cam\.txt has no P_rect_02"):
        read_calibration(write_raw_day(tmp_path / "no_p", drop="P_rect_02"))
    with pytest.raises(CalibrationError, match=r"calib_velo_to_cam\.txt has no T"):
        read_calibration(write_raw_day(tmp_path / "no_t", drop="T"))
    with pytest.raises(CalibrationError, match="camera 2 or 3, not 0"):
        read_calibration(tmp_path / "ok", camera=0)
    (tmp_path / "empty").mkdir()
    with pytest.raises(CalibrationError, match="is not a calibration: expected a KITTI raw day folder"):
        read_calibration(tmp_path / "empty")
    with pytest.raises(FileNotFoundError, match="calibration not found"):
        read_calibration(tmp_path / "nowhere")
    odo = tmp_path / "calib.txt"
    odo.write_text("P2: 700 0 600 40 0 700 180 0 0 0 1 0\nTr: 0 -1 0 0 0 0 -1 0 1 0 0 0\n")
    with pytest.raises(CalibrationError, match=r"holds no image size; give it \(--size WxH"):
        read_calibration(odo).image_size()
    assert read_calibration(odo, size=(1226, 370)).image_size() == (1226, 370)
    odo.write_text("P2: 700 0 600\nTr: 0 -1 0 0 0 0 -1 0 1 0 0 0\n")
    with pytest.raises(CalibrationError, match="P2 holds 3 numbers, expected 12"):
        read_calibration(odo)


@pytest.mark.parametrize("text, want", [("1226x370", (1226, 370)), ("640X480", (640, 480))])
def test_parse_size(text, want):
    assert parse_size(text) == want


@pytest.mark.parametrize("text", ["1226", "axb", "0x10", "-5x3"])
def test_parse_size_refuses_what_is_not_a_size(text):
    with pytest.raises(ValueError, match="WIDTHxHEIGHT|not a camera image"):
        parse_size(text)
