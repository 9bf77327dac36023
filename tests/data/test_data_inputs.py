"""Input kinds: a dataset's measured input (the map itself, or a separate LiDAR scan) and its pairs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from inpaintenv.data import (
    ArrayDataset, ConcatDataset, KittiDepth, SyntheticStreets, Subset, open_source, select_drives, split_by_drive,
    write_depth_png,
)
from inpaintenv.exceptions import InvalidInputError

SHAPE = (64, 256)


@pytest.fixture(scope="module")
def scans() -> SyntheticStreets:
    return SyntheticStreets(n=6, seed=3, frame_shape=SHAPE, frames_per_drive=3, input="scan")


def test_map_input_is_the_frame_itself():
    ds = SyntheticStreets(n=2, frame_shape=SHAPE)
    assert ds.input_kind == "map"
    inputs, gt = ds.load_pairs([1, 0])
    assert inputs is gt
    np.testing.assert_array_equal(gt, ds.load_batch([1, 0]))
    np.testing.assert_array_equal(ds.load_input_batch([0]), ds.load_batch([0]))
    np.testing.assert_array_equal(ds.input_frame(-1), ds[1])


def test_synthetic_scan_pairs_the_scan_and_the_truth_of_one_render(scans):
    idx = list(range(len(scans)))
    inputs, gt = scans.load_pairs(idx)
    # The scan is the frame's velodyne_raw, the target its accumulated ground truth.
    lidar = SyntheticStreets(n=6, seed=3, frame_shape=SHAPE, frames_per_drive=3, kind="velodyne_raw")
    truth = SyntheticStreets(n=6, seed=3, frame_shape=SHAPE, frames_per_drive=3)
    np.testing.assert_array_equal(inputs, lidar.load_batch(idx))
    np.testing.assert_array_equal(gt, truth.load_batch(idx))
    np.testing.assert_array_equal(scans.load_input_batch(idx), inputs)
    np.testing.assert_array_equal(scans.input_frame(2), inputs[2])
    # Every scan pixel lies on the rendered scene; the scan is sparser than its truth.
    dense = SyntheticStreets(n=6, seed=3, frame_shape=SHAPE, frames_per_drive=3, kind="dense").load_batch(idx)
    measured = inputs > 0
    np.testing.assert_array_equal(inputs[measured], dense[measured])
    density = measured.mean(axis=(1, 2))
    assert np.all(density > 0.01) and np.all(density < (gt > 0).mean(axis=(1, 2)))


def test_views_keep_the_input_kind(scans):
    sub = scans[[4, 1]]
    assert isinstance(sub, Subset) and sub.input_kind == "scan"
    np.testing.assert_array_equal(sub.load_input_batch([0, 1]), scans.load_input_batch([4, 1]))
    drive = scans.groups[0]
    assert select_drives(scans, [drive]).input_kind == "scan"
    assert all(part.input_kind == "scan" for part in split_by_drive(scans, test_size=1))
    both = ConcatDataset([scans, sub])
    assert both.input_kind == "scan"
    inputs, gt = both.load_pairs([len(scans)])
    np.testing.assert_array_equal(inputs[0], scans.input_frame(4))
    np.testing.assert_array_equal(gt[0], scans[4])


def test_concatenating_a_scan_source_with_a_map_source_is_refused(scans):
    with pytest.raises(InvalidInputError, match="different input kinds"):
        ConcatDataset([scans, SyntheticStreets(n=2, frame_shape=SHAPE)])


def test_array_dataset_with_inputs():
    gt = np.full((2, 8, 8), 5.0, np.float32)
    scan = np.zeros_like(gt)
    scan[:, ::3, ::3] = 5.0
    ds = ArrayDataset(gt, inputs=scan)
    assert ds.input_kind == "scan"
    inputs, truth = ds.load_pairs([1])
    np.testing.assert_array_equal(inputs[0], scan[1])
    np.testing.assert_array_equal(truth[0], gt[1])
    with pytest.raises(InvalidInputError, match="inputs has shape"):
        ArrayDataset(gt, inputs=scan[:1])
    with pytest.raises(ValueError, match="inputs"):
        ArrayDataset(gt, inputs=np.full_like(gt, np.nan))


@pytest.mark.parametrize("make", [
    lambda: SyntheticStreets(n=2, input="lidar"),
    lambda: SyntheticStreets(n=2, kind="velodyne_raw", input="scan"),
    lambda: open_source(input="both"),
])
def test_bad_input_kinds_are_refused(make):
    with pytest.raises(InvalidInputError, match="input"):
        make()


def test_open_source_gives_the_scan_kind():
    ds = open_source(n_frames=2, input="scan")
    assert ds.input_kind == "scan" and len(ds) == 2


def _write(path: Path, value: float) -> None:
    depth = np.zeros((10, 14))
    depth[::2, ::2] = value
    write_depth_png(path, depth)


def test_kitti_pairs_each_frame_with_its_own_scan(tmp_path):
    base = tmp_path / "train" / "2011_09_26_drive_0001_sync" / "proj_depth"
    for f in (5, 6, 7):
        _write(base / "groundtruth" / "image_02" / f"{f:010d}.png", 10.0 + f)
    for f in (6, 7, 8):  # frame 5 has no scan, frame 8 no truth: both left out
        _write(base / "velodyne_raw" / "image_02" / f"{f:010d}.png", 20.0 + f)
    ds = KittiDepth(tmp_path, split="train", crop=(8, 12), input="scan")
    assert ds.input_kind == "scan"
    assert [fid.rsplit("/", 1)[1] for fid in ds.frame_ids] == ["0000000006", "0000000007"]
    inputs, gt = ds.load_pairs([0, 1])
    assert inputs.shape == gt.shape == (2, 8, 12)
    assert set(np.unique(inputs[1])) == {0.0, 27.0} and set(np.unique(gt[1])) == {0.0, 17.0}
    assert np.array_equal(inputs > 0, gt > 0)  # cropped identically
    with pytest.raises(InvalidInputError, match="kind must be 'groundtruth'"):
        KittiDepth(tmp_path, split="train", kind="velodyne_raw", input="scan")


def test_kitti_without_any_scan_says_so(tmp_path):
    _write(tmp_path / "train" / "x_sync" / "proj_depth" / "groundtruth" / "image_02" / "0000000005.png", 3.0)
    with pytest.raises(FileNotFoundError, match="both its ground truth and its scan"):
        KittiDepth(tmp_path, split="train", crop=(8, 12), input="scan")


@pytest.mark.kitti
@pytest.mark.parametrize("split", ["train", "val", "val_selection"])
def test_real_kitti_scans(kitti_root, split):
    truth = KittiDepth(kitti_root, split=split)
    ds = KittiDepth(kitti_root, split=split, input="scan")
    # Every drive of the split has pairs.
    assert set(ds.groups) == set(truth.groups) and len(ds) > 0
    # First and last frame of each drive.
    idx = sorted({int(np.flatnonzero(ds.groups == d)[k]) for d in set(ds.groups) for k in (0, -1)})
    inputs, gt = ds.load_pairs(idx)
    density = (inputs > 0).mean(axis=(1, 2))
    assert np.all(density > 0.02) and np.all(density < 0.08), density
    assert np.all((gt > 0).mean(axis=(1, 2)) > density)  # each scan's frame has (denser) truth
    # The scan and its truth are of one frame: where both measure, they mostly agree.
    both = (inputs > 0) & (gt > 0)
    assert both.sum() > 0.5 * (inputs > 0).sum()
    assert np.median(np.abs(inputs[both] - gt[both])) < 0.1


def test_a_scan_source_is_not_cached_as_maps(scans, tmp_path):
    from inpaintenv.data import CachedDataset

    with pytest.raises(InvalidInputError, match="input kind 'scan'"):
        CachedDataset(scans, tmp_path)
