"""``fill --missing`` densifies within the scan's field of view, not the sky."""

from __future__ import annotations

import numpy as np
import pytest

from inpaintenv.cli import main
from inpaintenv.data import project_points, project_scan, read_calibration, read_depth_png, read_scan, write_depth_png
from inpaintenv.filling import fill
from inpaintenv.filling.view import sensor_view


def banded(shape=(40, 120)) -> np.ndarray:
    """A scan-like map: beams on every other row from row 12 (16 at the right) down to row 33; column 50 empty."""
    h, w = shape
    d = np.zeros(shape, np.float32)
    for c in range(w):
        top = 12 if c < 80 else 16
        d[top:34:2, c] = 5.0 + c / 100
    d[:, 50] = 0.0
    return d


def test_the_view_runs_per_column_from_the_top_to_the_bottom_measured_row():
    d = banded()
    view = sensor_view(d)
    assert view[12:33, :70].all() and not view[:12].any() and not view[33:].any()
    assert view[12:33, 50].all()  # a column without measurement takes its neighbours' edges
    assert not view[12:16, 100:].any() and view[16:33, 100:].all()  # the edge follows the columns' tops
    assert not sensor_view(np.zeros((16, 16))).any()
    d[0, 0] = np.nan
    np.testing.assert_array_equal(sensor_view(d), view)


def test_missing_leaves_the_sky_and_fill_all_fills_it(tmp_path, capsys):
    d = banded()
    write_depth_png(tmp_path / "in" / "a.png", d)
    assert main(["fill", str(tmp_path / "in"), "--missing", "-m", "nearest", "--out", str(tmp_path / "v"), "-q"]) == 0
    got = read_depth_png(tmp_path / "v" / "a.png")
    view = sensor_view(d)
    assert (got[view] > 0).all() and (got[~view] == 0).all()
    assert main(["fill", str(tmp_path / "in"), "--missing", "--fill-all", "-m", "nearest",
                 "--out", str(tmp_path / "all"), "-q"]) == 0
    assert (read_depth_png(tmp_path / "all" / "a.png") > 0).all()
    capsys.readouterr()
    assert main(["fill", str(tmp_path / "in"), "--fill-all", "--out", str(tmp_path / "x"), "-q"]) != 0
    # One check, where the options are made (FillOptions), for the command and Python alike.
    assert "fill_all (--fill-all) widens missing (--missing) to every pixel without a measurement; give missing " \
        "too (--missing)" in capsys.readouterr().err


def test_holes_and_boxes_are_filled_outside_the_view_too(tmp_path):
    d = banded()
    write_depth_png(tmp_path / "in" / "a.png", d)
    assert fill([tmp_path / "in"], tmp_path / "out", method="nearest", missing=True, boxes=[(0, 0, 10, 5)],
                progress=False).ok
    assert (read_depth_png(tmp_path / "out" / "a.png")[:5, :10] > 0).all()


def _elevation(points: np.ndarray) -> np.ndarray:
    return np.degrees(np.arctan2(points[:, 2], np.hypot(points[:, 0], points[:, 1])))


@pytest.mark.kitti
def test_densified_points_of_a_kitti360_scan_lie_in_its_field_of_view(kitti_raw_root, tmp_path):
    scans = kitti_raw_root / "kitti360/2013_05_28_drive_0000_sync/velodyne_points/data"
    calib_dir = kitti_raw_root / "kitti360/calibration"
    name = sorted(scans.glob("*.bin"))[0].name
    calib = read_calibration(calib_dir)
    original = read_scan(scans / name)
    depth, index = project_scan(original, calib, return_index=True)
    top = _elevation(original[np.unique(index[index >= 0])]).max()
    view = sensor_view(depth)
    above = {}
    for extra in ([], ["--fill-all"]):
        out = tmp_path / ("all" if extra else "view")
        assert main(["fill", str(scans), "--calib", str(calib_dir), "--missing", *extra, "--points", "bin",
                     "-m", "nearest", "--out", str(out), "-q"]) == 0
        new = read_scan(out / name)[len(original):]
        above[bool(extra)] = float(np.mean(_elevation(new) > top))
        if not extra:
            u, v, _ = project_points(new, calib)
            assert view[np.rint(v).astype(int), np.rint(u).astype(int)].all()  # every new point is in the view
            assert len(new) == np.count_nonzero(view & (depth == 0))
    assert above[False] < 0.01 < 0.1 < above[True]  # the sky's points are gone
