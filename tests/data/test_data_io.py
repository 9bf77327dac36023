"""Reading/writing KITTI depth PNGs: round trip and every malformed-file error."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from inpaintenv.data import DepthFormatError, png_header, read_depth_png, write_depth_png


def test_round_trip_is_exact_at_kitti_resolution(tmp_path, rng):
    depth = np.round(rng.uniform(0, 90, size=(7, 11)) * 256) / 256
    depth[rng.random(depth.shape) < 0.5] = 0.0
    path = tmp_path / "sub" / "d.png"
    write_depth_png(path, depth)
    back = read_depth_png(path)
    assert back.dtype == np.float32 and back.shape == (7, 11)
    np.testing.assert_array_equal(back, depth.astype(np.float32))
    h = png_header(path)
    assert (h.width, h.height, h.bit_depth, h.color_type) == (11, 7, 16, 0)


def test_eight_bit_png_is_rejected(tmp_path):
    path = tmp_path / "d8.png"
    cv2.imwrite(str(path), np.full((4, 5), 7, np.uint8))
    with pytest.raises(DepthFormatError, match="8-bit"):
        read_depth_png(path)


def test_rgb_png_is_rejected(tmp_path):
    path = tmp_path / "rgb.png"
    cv2.imwrite(str(path), np.full((4, 5, 3), 700, np.uint16))
    with pytest.raises(DepthFormatError, match="3 channels"):
        read_depth_png(path)


def test_truncated_png_names_the_file(tmp_path, rng):
    path = tmp_path / "trunc.png"
    write_depth_png(path, rng.uniform(1, 50, size=(40, 50)))
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(DepthFormatError, match="trunc.png"):
        read_depth_png(path)


def test_not_a_png(tmp_path):
    path = tmp_path / "text.png"
    path.write_text("hello")
    with pytest.raises(DepthFormatError):
        read_depth_png(path)
    with pytest.raises(DepthFormatError, match="not a PNG"):
        png_header(path)


def test_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.png"):
        read_depth_png(tmp_path / "nope.png")


@pytest.mark.parametrize(
    "bad, match",
    [(np.full((2, 2), -1.0), "negative"), (np.full((2, 2), np.nan), "NaN"), (np.full((2, 2), 300.0), "255.99"), (np.zeros(3), "2-D")],
)
def test_write_rejects_bad_depth(tmp_path, bad, match):
    with pytest.raises(ValueError, match=match):
        write_depth_png(tmp_path / "x.png", bad)


@pytest.mark.parametrize("name", ["d.jpg", "d", "d.PNG.bak"])
def test_write_requires_a_png_suffix(tmp_path, name):
    # cv2 picks the format from the suffix: .jpg silently wrote 8 bits.
    with pytest.raises(ValueError, match="must end in .png"):
        write_depth_png(tmp_path / name, np.ones((2, 2)))
    assert not (tmp_path / name).exists()


@pytest.mark.parametrize(
    "bad, error, match",
    [
        (np.ones((2, 2), bool), TypeError, "boolean"),
        (np.ones((2, 2), complex), TypeError, "real numeric"),
        (np.zeros((0, 5)), ValueError, "empty"),
        (np.ones((2, 2, 1)), ValueError, "2-D"),
        (np.full((2, 2), np.inf), ValueError, "infinite"),
    ],
)
def test_write_rejects_bad_arrays_before_opencv(tmp_path, bad, error, match):
    with pytest.raises(error, match=match):
        write_depth_png(tmp_path / "x.png", bad)
