"""CachedDataset: lossless for KITTI, rounding for synthetic data, stale caches, pickling."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from inpaintenv.data import ArrayDataset, DepthDataset, KittiDepth, SyntheticStreets
from inpaintenv.data.cache import (
    CachedDataset,
    StaleCacheError,
    encode_depth,
    estimate_cache_bytes,
    format_bytes,
)


@pytest.fixture
def frames(small_gt) -> ArrayDataset:
    return ArrayDataset(small_gt, groups=["a", "a", "b"])


def test_is_a_dataset_with_the_same_ids_and_groups(frames, tmp_path):
    ds = CachedDataset(frames, tmp_path / "c")
    assert isinstance(ds, DepthDataset)
    assert ds.frame_ids == frames.frame_ids
    assert list(ds.groups) == list(frames.groups)
    assert ds.shape == frames.shape and len(ds) == 3


def test_lazy_fill_then_served_from_disk(frames, tmp_path):
    ds = CachedDataset(frames, tmp_path / "c")
    assert ds.n_cached == 0
    first = ds[1]
    assert ds.n_cached == 1
    # A fresh object on the same folder reads frame 1 from the memmap.
    again = CachedDataset(frames, tmp_path / "c")
    assert again.n_cached == 1
    np.testing.assert_array_equal(again[1], first)
    assert first.dtype == np.float32 and first.flags.c_contiguous


def test_synthetic_values_are_rounded_to_a_256th_of_a_metre(tmp_path):
    src = SyntheticStreets(n=2, seed=3, frame_shape=(24, 64), frames_per_drive=2)
    ds = CachedDataset(src, tmp_path / "c").build(progress=False)
    for i in range(2):
        np.testing.assert_allclose(ds[i], src[i], atol=1 / 512 + 1e-6, rtol=0)
        # Exactly the rounded value, cached or not.
        np.testing.assert_array_equal(ds[i], np.rint(src[i] * 256).astype(np.uint16) / np.float32(256))
    assert (ds.load_batch([1, 0]) == np.stack([ds[1], ds[0]])).all()


def test_kitti_cache_is_lossless(kitti_root, tmp_path):
    src = KittiDepth(kitti_root, split="train", crop=(64, 96), drives=["2011_09_26_drive_9002_sync"])
    ds = CachedDataset(src, tmp_path / "c").build(progress=False)
    assert ds.n_cached == len(src)
    for i in (0, len(src) // 2, len(src) - 1):
        np.testing.assert_array_equal(ds[i], src[i])
    np.testing.assert_array_equal(ds.load_batch(range(len(src))), src.load_batch(range(len(src))))
    assert ds.verify() == []


def test_build_prints_the_size_first(frames, tmp_path, capsys):
    ds = CachedDataset(frames, tmp_path / "c")
    ds.build(progress=True)
    out = capsys.readouterr().out
    assert format_bytes(estimate_cache_bytes(frames)) in out and "3 to decode" in out
    assert ds.n_cached == 3
    assert (tmp_path / "c" / "frames.npy").stat().st_size >= 3 * 32 * 48 * 2


def test_estimate_is_two_bytes_per_pixel_plus_overhead(frames):
    n_pixels = 3 * 32 * 48
    assert 2 * n_pixels < estimate_cache_bytes(frames) < 2 * n_pixels + 4096
    assert format_bytes(1536) == "1.5 KiB" and format_bytes(10) == "10 B"


@pytest.mark.parametrize("change", ["ids", "shape", "source"])
def test_stale_cache_is_detected(frames, small_gt, tmp_path, change):
    CachedDataset(frames, tmp_path / "c")[0]
    if change == "ids":
        other = ArrayDataset(small_gt, groups=["x", "y", "z"])
    elif change == "shape":
        other = ArrayDataset(small_gt[:, :16])
        other.groups, other.frame_ids = frames.groups, frames.frame_ids
    else:
        other = SyntheticStreets(n=3, frame_shape=(32, 48))
        other.frame_ids = frames.frame_ids
    with pytest.raises(StaleCacheError, match="other frames"):
        CachedDataset(other, tmp_path / "c")
    rebuilt = CachedDataset(other, tmp_path / "c", on_stale="rebuild")
    assert rebuilt.n_cached == 0
    np.testing.assert_allclose(rebuilt[0], other[0], atol=1 / 512 + 1e-6)


def test_kind_changes_the_key(tmp_path):
    # Same frame ids, different pixels: the cache must not serve one for the other.
    CachedDataset(SyntheticStreets(n=2, frame_shape=(16, 32), kind="dense"), tmp_path / "c")
    with pytest.raises(StaleCacheError, match="source"):
        CachedDataset(SyntheticStreets(n=2, frame_shape=(16, 32), kind="groundtruth"), tmp_path / "c")


def test_truncated_frames_file_is_reported(frames, tmp_path):
    CachedDataset(frames, tmp_path / "c").build(progress=False)
    path = tmp_path / "c" / "frames.npy"
    path.write_bytes(path.read_bytes()[:200])
    with pytest.raises(StaleCacheError, match="frames.npy"):
        CachedDataset(frames, tmp_path / "c")


def test_pickles_without_open_memmaps_and_shares_the_cache(frames, tmp_path):
    ds = CachedDataset(frames, tmp_path / "c")
    ds[0]
    clone = pickle.loads(pickle.dumps(ds))
    assert clone._frames is None
    clone[2]
    assert ds.n_cached == 2  # the clone wrote into the same files


def test_bad_arguments(frames, tmp_path):
    with pytest.raises(TypeError, match="DepthDataset"):
        CachedDataset(np.zeros((2, 4, 4)), tmp_path)
    with pytest.raises(ValueError, match="on_stale"):
        CachedDataset(frames, tmp_path, on_stale="ignore")
    with pytest.raises(IndexError):
        CachedDataset(frames, tmp_path / "c").load_batch([5])


class _Unchecked(DepthDataset):
    """Frames served as given (ArrayDataset itself would refuse depth above 255.996 m)."""

    def __init__(self, frames):
        self._frames = frames
        self.frame_shape = frames.shape[1:]
        self.groups = np.asarray(["d"] * len(frames))
        self.frame_ids = [f"d/{i}" for i in range(len(frames))]

    def _load(self, index):
        return self._frames[index]


def test_unencodable_depth_is_a_clear_error(tmp_path):
    far = _Unchecked(np.full((1, 4, 4), 300.0, dtype=np.float32))
    with pytest.raises(ValueError, match="255.99 m"):
        CachedDataset(far, tmp_path / "c")[0]
    with pytest.raises(ValueError, match="finite"):
        encode_depth(np.array([[np.nan]]))
