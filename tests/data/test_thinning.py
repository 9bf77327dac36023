"""Scan thinning: a laser ring per point, every k-th ring kept, a seeded share of points kept.

The synthetic scans are built ring by ring (two blocks of lasers at their own heights, the
lower block tilted across azimuth, as measured on KITTI's HDL-64E), so each point's true
ring is known. The ``kitti`` tests thin a few real scans of each recording day: every
ring kept forms one continuous curve in the image and the share kept is about 1/k.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from inpaintenv.data import KittiDepth
from inpaintenv.data.calibration import Calibration, read_calibration
from inpaintenv.data.io import read_depth_png
from inpaintenv.data.projection import project_scan
from inpaintenv.data.thinning import (
    LASER_HEIGHTS, laser_rings, ring_map, thin_points_by_rings, thin_points_by_share, thin_scan_by_points,
    thin_scan_by_rings,
)
from inpaintenv.exceptions import InpaintenvError

# Elevations (degrees) of a 64-beam sensor's rings as the slice's scans show them.
UPPER = np.linspace(2.0, -8.75, 32)
LOWER = np.linspace(-9.45, -24.8, 32)
# The 2011_09_26 projection into camera 2 (P_rect_02 R_rect_00 [R|T]_velo_to_cam), rounded.
KITTI_LIKE = np.array([
    [609.70, -721.42, -1.2513, -123.04],
    [180.38, 7.645, -719.65, -101.02],
    [0.9999, 0.0001, 0.0105, -0.2694],
])


def synthetic_scan(rng: np.random.Generator, azimuth_deg: float = 45.0, tilt_deg: float = 0.25) -> tuple[np.ndarray, np.ndarray]:
    """``(points, ring)``: each ring swept over +-``azimuth_deg``, ranges 3-60 m, the lower block tilted."""
    az = np.deg2rad(np.arange(-azimuth_deg, azimuth_deg, 0.17))
    elev = np.concatenate([UPPER, LOWER])
    ring = np.repeat(np.arange(64), len(az))
    a = np.tile(az, 64)
    e = np.deg2rad(np.repeat(elev, len(az)) + np.where(ring >= 32, tilt_deg, 0.0) * np.sin(a))
    r = rng.uniform(3.0, 60.0, len(a))
    height = np.where(ring >= 32, LASER_HEIGHTS[1], LASER_HEIGHTS[0])
    points = np.stack([r * np.cos(a), r * np.sin(a), height + r * np.tan(e), np.zeros_like(r)], axis=1)
    keep = rng.random(len(a)) < 0.8  # dropped returns, as real scans have
    return points[keep].astype(np.float32), ring[keep]


@pytest.fixture(scope="module")
def scan():
    return synthetic_scan(np.random.default_rng(3))


def test_laser_rings_recover_every_ring_in_order(scan):
    points, ring = scan
    np.testing.assert_array_equal(laser_rings(points), ring)


def test_thin_points_by_rings_keeps_every_kth_ring(scan):
    points, ring = scan
    np.testing.assert_array_equal(thin_points_by_rings(points, 4), points[ring % 4 == 0])


def test_ring_map_of_a_projected_scan_gives_each_pixel_its_points_ring(scan):
    points, ring = scan
    calib = Calibration(KITTI_LIKE, (1242, 375), "raw")
    depth, index = project_scan(points, calib, return_index=True)
    rings = ring_map(depth, calib)
    measured = index >= 0
    assert np.count_nonzero(measured) > 5000
    true = ring[index[measured]]
    # A ring only a few of whose points reach the image cannot be told from stray points.
    seen = np.bincount(true)[true] >= 5
    np.testing.assert_array_equal(rings[measured][seen], true[seen] - true.min())
    assert (rings[~measured] == -1).all()
    thinned = thin_scan_by_rings(depth, calib, keep_every=4)
    np.testing.assert_array_equal(thinned != 0, measured & (rings % 4 == 0))
    assert 0.2 < np.count_nonzero(thinned) / np.count_nonzero(measured) < 0.3
    np.testing.assert_array_equal(thinned[thinned != 0], depth[thinned != 0])


def test_keep_every_one_keeps_the_scan(scan):
    calib = Calibration(KITTI_LIKE, (1242, 375), "raw")
    depth = project_scan(scan[0], calib)
    np.testing.assert_array_equal(thin_scan_by_rings(depth, calib, 1), depth)


def test_point_thinning_keeps_the_share_seeded():
    rng = np.random.default_rng(0)
    depth = np.where(rng.random((40, 60)) < 0.1, rng.uniform(1, 80, (40, 60)), 0.0).astype(np.float32)
    depth[0, 0] = np.nan  # NaN is no measurement
    n = np.count_nonzero(depth > 0)
    for share in (0.5, 0.25, 0.1):
        a = thin_scan_by_points(depth, share, seed=7)
        assert np.count_nonzero(a) == round(share * n)
        np.testing.assert_array_equal(a[a > 0], depth[a > 0])
        np.testing.assert_array_equal(a, thin_scan_by_points(depth, share, seed=7))
        assert not np.array_equal(a, thin_scan_by_points(depth, share, seed=8))
    pts = rng.random((1000, 4)).astype(np.float32)
    kept = thin_points_by_share(pts, 0.25, seed=1)
    assert len(kept) == 250 and np.isin(kept[:, 0], pts[:, 0]).all()


@pytest.mark.parametrize("call", [
    lambda d, c: thin_scan_by_rings(d, c, 0),
    lambda d, c: thin_scan_by_rings(d, c, True),
    lambda d, c: thin_scan_by_rings(d, c, 2.5),
    lambda d, c: thin_scan_by_rings(d[None], c, 2),
    lambda d, c: thin_scan_by_points(d, 0.0, 0),
    lambda d, c: thin_scan_by_points(d, 1.5, 0),
    lambda d, c: thin_scan_by_points(d, 0.5, -1),
    lambda d, c: laser_rings(np.full((3, 3), np.nan)),
])
def test_bad_arguments_are_one_clear_error(call):
    calib = Calibration(KITTI_LIKE, (1242, 375), "raw")
    with pytest.raises(InpaintenvError):
        call(np.zeros((375, 1242), dtype=np.float32), calib)


def ring_curves_are_continuous(rings: np.ndarray, depth: np.ndarray) -> float:
    """Share of neighbouring points of one ring (within 3 columns, depth within 5 %) more than 2 rows apart."""
    rows, cols = np.nonzero(rings >= 0)
    ring, z = rings[rows, cols], depth[rows, cols]
    order = np.lexsort((cols, ring))
    rows, cols, ring, z = rows[order], cols[order], ring[order], z[order]
    neighbours = (ring[1:] == ring[:-1]) & (cols[1:] - cols[:-1] <= 3) & (np.abs(z[1:] - z[:-1]) < 0.05 * z[1:])
    return float(np.mean(np.abs(np.diff(rows))[neighbours] > 2))


def day_scans(root: Path, day: str, per_drive: int = 1) -> list[Path]:
    """The first scan of each drive of ``day`` (a few real frames, however many drives the slice has)."""
    out = []
    for drive in sorted((root / "train").glob(f"{day}_drive_*_sync")):
        out += sorted((drive / "proj_depth" / "velodyne_raw" / "image_02").glob("*.png"))[:per_drive]
    return out[:2]


@pytest.mark.kitti
@pytest.mark.parametrize("day", ["2011_09_26", "2011_09_30", "2011_10_03"])
def test_ring_thinning_on_real_scans_of_each_day(kitti_root, day):
    scans = day_scans(kitti_root, day)
    assert scans, f"no velodyne_raw scan of {day} in the slice"
    for path in scans:
        depth = read_depth_png(path)
        calib = read_calibration(kitti_root / "calib" / day, size=(depth.shape[1], depth.shape[0]))
        rings = ring_map(depth, calib)
        n_rings = int(rings.max()) + 1
        assert 40 <= n_rings <= 64, f"{path.name}: {n_rings} rings (an HDL-64E shows about 46 in the image)"
        # Each ring is one curve: neighbouring points of a ring lie on neighbouring rows.
        assert ring_curves_are_continuous(rings, depth) < 0.01, path
        measured = np.count_nonzero(depth > 0)
        thinned = thin_scan_by_rings(depth, calib, 4)  # the rings found again: the same ones
        np.testing.assert_array_equal(thinned, np.where((rings >= 0) & (rings % 4 == 0), depth, 0))
        for k in (2, 4, 8):
            share = np.count_nonzero((rings >= 0) & (rings % k == 0)) / measured
            assert 0.8 / k < share < 1.2 / k, f"{path.name}: keeping every {k}th ring kept {share:.3f}"
            assert ring_curves_are_continuous(np.where(rings % k == 0, rings, -1), depth) < 0.01


@pytest.mark.kitti
@pytest.mark.parametrize("day", ["2011_09_26", "2011_09_30", "2011_10_03"])
def test_kitti_depth_ring_variant_on_cropped_frames_of_each_day(kitti_root, day):
    """``KittiDepth(input="scan-rings16-v1")``: the day's calibration shifted to the crop; every 4th ring kept."""
    drive = sorted(p.name for p in (kitti_root / "train").glob(f"{day}_drive_*_sync"))[0]
    thinned = KittiDepth(kitti_root, split="train", drives=[drive], input="scan-rings16-v1")
    full = KittiDepth(kitti_root, split="train", drives=[drive], input="scan")
    calibration, height = thinned.scan_calibration(0)
    assert calibration.size == (thinned.frame_shape[1], thinned.frame_shape[0])
    for i in range(min(2, len(thinned))):
        scan, mine = full.input_frame(i), thinned.input_frame(i)
        np.testing.assert_array_equal(mine[mine > 0], scan[mine > 0])
        assert 0.8 / 4 < np.count_nonzero(mine) / np.count_nonzero(scan) < 1.2 / 4
        rings = ring_map(scan, calibration, height)
        assert 40 <= rings.max() + 1 <= 64 and ring_curves_are_continuous(rings, scan) < 0.01
