"""open_source: split lists, drive selection, and ConcatDataset."""

from __future__ import annotations

import numpy as np
import pytest

from inpaintenv.data import open_source


def test_concat_splits_and_drive_selection_on_real_slice(kitti_root, kitti_layout):
    counts = {**kitti_layout("train"), **kitti_layout("val")}
    excluded = "2011_09_26_drive_9001_sync"
    ds = open_source(kitti_root, split="train,val", exclude_drives=[excluded])
    kept = {d: n for d, n in counts.items() if d != excluded}
    assert sorted(set(ds.groups)) == sorted(kept)
    assert len(ds) == sum(kept.values())
    assert ds[len(ds) - 1].shape == (352, 1216)  # the val frame (another size) is cropped alike
    drive = sorted(kept)[-1]  # any kept drive: its frames in the concatenation equal a selection of it alone
    only = open_source(kitti_root, split="train,val", drives=[drive])
    assert len(only) == counts[drive] and set(only.groups) == {drive}
    first = list(ds.groups).index(drive)
    np.testing.assert_array_equal(only[0], ds[first])
    np.testing.assert_array_equal(only[len(only) - 1], ds[first + len(only) - 1])


def test_drive_selection_errors():
    with pytest.raises(ValueError, match="unknown drives"):
        open_source(n_frames=16, drives=["nope"])
    ds = open_source(n_frames=16)
    first = ds.groups[0]
    kept = open_source(n_frames=16, drives=[first])
    assert set(kept.groups) == {first}
    with pytest.raises(ValueError, match="no frames left"):
        open_source(n_frames=16, drives=[first], exclude_drives=[first])


def test_concat_dataset_indexing():
    from inpaintenv.data import ArrayDataset, ConcatDataset

    a = ArrayDataset(np.ones((2, 8, 9), np.float32), groups=["a", "a"])
    b = ArrayDataset(np.full((3, 8, 9), 2.0, np.float32), groups=["b", "b", "b"])
    c = ConcatDataset([a, b])
    assert len(c) == 5 and list(c.groups) == ["a", "a", "b", "b", "b"]
    assert c[1][0, 0] == 1.0 and c[2][0, 0] == 2.0 and c[-1][0, 0] == 2.0
    with pytest.raises(ValueError, match="different frame sizes"):
        ConcatDataset([a, ArrayDataset(np.ones((1, 9, 8), np.float32))])
