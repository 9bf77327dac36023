"""read_depth_png on hostile files: only FileNotFoundError / DepthFormatError, never wrong depth."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from fuzz_settings import fast
from hypothesis import given
from hypothesis import strategies as st

from inpaintenv.data.io import DepthFormatError, read_depth_png

sizes = st.tuples(st.integers(1, 24), st.integers(1, 40))


def _png_bytes(img: np.ndarray) -> bytes:
    ok, buf = cv2.imencode(".png", img)
    assert ok
    return buf.tobytes()


@fast(40)
@given(data=st.binary(max_size=2048))
def test_random_bytes_are_rejected_or_decoded_as_16_bit(tmp_path_factory, data):
    path = tmp_path_factory.mktemp("bytes") / "x.png"
    path.write_bytes(data)
    try:
        depth = read_depth_png(path)
    except DepthFormatError:
        return
    # Only a genuine single-channel 16-bit image may get through.
    assert depth.ndim == 2 and depth.dtype == np.float32


@fast(30)
@given(size=sizes, seed=st.integers(0, 2**32 - 1), cut=st.floats(0.0, 1.0, exclude_max=True))
def test_truncated_png_is_an_error_or_exact(tmp_path_factory, size, seed, cut):
    codes = np.random.default_rng(seed).integers(0, 2**16, size=size, dtype=np.uint16)
    blob = _png_bytes(codes)
    path = tmp_path_factory.mktemp("trunc") / "x.png"
    path.write_bytes(blob[: int(cut * len(blob))])
    try:
        depth = read_depth_png(path)
    except DepthFormatError:
        return
    # If the decoder accepts a shortened file, the pixels must still be exactly right.
    np.testing.assert_array_equal(depth, codes.astype(np.float32) / 256)


@fast(30)
@given(
    size=sizes,
    seed=st.integers(0, 2**32 - 1),
    layout=st.sampled_from(["gray8", "rgb8", "rgb16", "rgba16", "gray16"]),
)
def test_pixel_formats(tmp_path_factory, size, seed, layout):
    rng = np.random.default_rng(seed)
    dtype = np.uint16 if layout.endswith("16") else np.uint8
    channels = {"gray": (), "rgb": (3,), "rgba": (4,)}[layout[:-2] if layout.endswith("16") else layout[:-1]]
    img = rng.integers(0, np.iinfo(dtype).max + 1, size=(*size, *channels), dtype=dtype)
    path = tmp_path_factory.mktemp("fmt") / "x.png"
    path.write_bytes(_png_bytes(img))
    if layout == "gray16":
        np.testing.assert_array_equal(read_depth_png(path), img.astype(np.float32) / 256)
    else:
        with pytest.raises(DepthFormatError, match="16-bit|channels"):
            read_depth_png(path)


def test_missing_file_and_folder(tmp_path):
    with pytest.raises(FileNotFoundError):
        read_depth_png(tmp_path / "absent.png")
    with pytest.raises(FileNotFoundError):
        read_depth_png(tmp_path)
    (tmp_path / "empty.png").write_bytes(b"")
    with pytest.raises(DepthFormatError):
        read_depth_png(tmp_path / "empty.png")
