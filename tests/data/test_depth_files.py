"""Depth maps and hole masks as PNG / .npy / .npz files (inpaintenv.data.depth_files)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from inpaintenv.data import DepthFormatError, read_depth_file, read_mask_file, write_depth_file


@pytest.fixture
def depth() -> np.ndarray:
    d = np.linspace(1.0, 60.0, 24 * 32, dtype=np.float32).reshape(24, 32)
    d[::3, ::2] = 0.0
    d[5:9, 10:20] = np.nan
    return d


@pytest.mark.parametrize("dtype", [np.float32, np.float64, np.float16])
@pytest.mark.parametrize("suffix", [".npy", ".npz"])
def test_arrays_round_trip_bit_identical_in_their_dtype(tmp_path, depth, dtype, suffix):
    d = depth.astype(dtype)
    write_depth_file(tmp_path / f"d{suffix}", d)
    back = read_depth_file(tmp_path / f"d{suffix}")
    assert back.dtype == dtype
    np.testing.assert_array_equal(back, d)  # NaN where NaN


def test_png_round_trips_at_the_kitti_step(tmp_path, depth):
    d = np.nan_to_num(depth, nan=0.0)
    write_depth_file(tmp_path / "d.png", d)
    back = read_depth_file(tmp_path / "d.png")
    assert back.dtype == np.float32
    np.testing.assert_array_equal(back, np.rint(d.astype(np.float64) * 256) / 256)


def test_npz_with_several_arrays_is_read_by_the_depth_key(tmp_path, depth):
    np.savez(tmp_path / "two.npz", depth=depth, other=np.zeros(3))
    np.testing.assert_array_equal(read_depth_file(tmp_path / "two.npz"), depth)
    np.savez(tmp_path / "ambiguous.npz", a=depth, b=depth)
    with pytest.raises(DepthFormatError, match=r"holds the arrays \['a', 'b'\]; name the depth"):
        read_depth_file(tmp_path / "ambiguous.npz")


@pytest.mark.parametrize("array, message", [
    (np.ones((8, 8), np.uint16), "integer dtype"),
    (np.ones((2, 8, 8), np.float32), "must be 2-D"),
    (-np.ones((8, 8), np.float32), "negative depth"),
    (np.full((8, 8), np.inf, np.float32), "infinite"),
])
def test_arrays_that_are_not_depth_maps_are_named(tmp_path, array, message):
    np.save(tmp_path / "bad.npy", array)
    with pytest.raises(DepthFormatError, match=rf"bad\.npy: .*{message}"):
        read_depth_file(tmp_path / "bad.npy")


def test_unreadable_files_are_named(tmp_path):
    (tmp_path / "trunc.npy").write_bytes(b"\x93NUMPY\x01\x00garbage")
    with pytest.raises(DepthFormatError, match=r"cannot read .*trunc\.npy"):
        read_depth_file(tmp_path / "trunc.npy")
    (tmp_path / "bad.npz").write_bytes(b"not a zip")
    with pytest.raises(DepthFormatError, match=r"cannot read .*bad\.npz"):
        read_depth_file(tmp_path / "bad.npz")
    (tmp_path / "x.tif").write_bytes(b"")
    with pytest.raises(DepthFormatError, match="not a depth file"):
        read_depth_file(tmp_path / "x.tif")
    with pytest.raises(FileNotFoundError, match="not found"):
        read_depth_file(tmp_path / "none.npy")
    with pytest.raises(ValueError, match="a depth file ends in"):
        write_depth_file(tmp_path / "d.tif", np.ones((8, 8), np.float32))


@pytest.mark.parametrize("image", [
    np.array([[0, 255], [0, 1]], np.uint8),
    np.array([[0, 65535], [0, 7]], np.uint16),
    np.dstack([np.array([[0, 0], [0, 9]], np.uint8), np.array([[0, 200], [0, 0]], np.uint8),
               np.zeros((2, 2), np.uint8)]),
    np.dstack([np.array([[0, 3], [0, 3]], np.uint8)] * 3 + [np.full((2, 2), 255, np.uint8)]),  # alpha ignored
])
def test_png_masks_are_nonzero_fill_in_any_depth_and_colour(tmp_path, image):
    cv2.imwrite(str(tmp_path / "m.png"), image)
    np.testing.assert_array_equal(read_mask_file(tmp_path / "m.png"), [[False, True], [False, True]])


def test_array_masks_and_their_errors(tmp_path):
    np.save(tmp_path / "m.npy", np.array([[0, 2.5], [0, -1]]))
    np.testing.assert_array_equal(read_mask_file(tmp_path / "m.npy"), [[False, True], [False, True]])
    np.savez(tmp_path / "m.npz", mask=np.eye(3, dtype=bool))
    np.testing.assert_array_equal(read_mask_file(tmp_path / "m.npz"), np.eye(3, dtype=bool))
    np.save(tmp_path / "nan.npy", np.array([[0, np.nan]]))
    with pytest.raises(DepthFormatError, match=r"nan\.npy: the mask holds NaN"):
        read_mask_file(tmp_path / "nan.npy")
    (tmp_path / "broken.png").write_bytes(b"\x89PNG\r\n\x1a\nbroken")
    with pytest.raises(DepthFormatError, match=r"broken\.png is truncated before the end of its PNG header"):
        read_mask_file(tmp_path / "broken.png")
