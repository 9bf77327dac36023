"""open_source(): synthetic by default (reproducible everywhere), KITTI only when asked."""

from __future__ import annotations

import pytest

from inpaintenv.data import KittiDepth, Subset, SyntheticStreets, open_source


def test_default_is_synthetic_even_with_the_environment_variable(monkeypatch, tmp_path):
    monkeypatch.setenv("INPAINTENV_KITTI_ROOT", str(tmp_path))
    ds = open_source()
    assert isinstance(ds, SyntheticStreets) and len(ds) == 64
    small = open_source(n_frames=5, seed=2, kind="velodyne_raw")
    assert len(small) == 5 and small.seed == 2 and small.kind == "velodyne_raw"


@pytest.mark.kitti
def test_kitti_when_a_root_is_given(kitti_root, kitti_layout):
    full = open_source(kitti_root)
    assert isinstance(full, KittiDepth) and len(full) == sum(kitti_layout("train").values())
    first = open_source(kitti_root, n_frames=7)
    assert isinstance(first, Subset) and first.frame_ids == full.frame_ids[:7]
    n_val = sum(kitti_layout("val").values())
    assert len(open_source(kitti_root, split="val", n_frames=10)) == min(n_val, 10)


@pytest.mark.parametrize("kwargs, match", [({"n_frames": 0}, "n_frames"), ({"n_frames": 2.5}, "n_frames")])
def test_bad_n_frames(kwargs, match):
    with pytest.raises(ValueError, match=match):
        open_source(**kwargs)


def test_dense_needs_synthetic(tmp_path):
    with pytest.raises(ValueError, match="dense"):
        open_source(tmp_path, kind="dense")
