"""The shared NaN / 0 / metres convention and its validation errors."""

from __future__ import annotations

import numpy as np
import pytest

from inpaintenv.conventions import (
    DEPTH_LIMIT,
    MIN_DEPTH,
    MIN_FRAME_SIDE,
    check_depth,
    check_int,
    check_mask,
    check_max_depth,
    check_seed,
    check_seeds,
    corrupt,
    in_depth_range,
)


def test_corrupt_marks_holes_with_nan_and_keeps_input():
    gt = np.array([[1.0, 0.0], [3.0, 4.0]], dtype=np.float32)
    hole = np.array([[True, True], [False, False]])
    x = corrupt(gt, hole)
    assert x.dtype == np.float32
    assert np.isnan(x[0]).all() and (x[1] == gt[1]).all()
    assert not np.isnan(gt).any()


def test_check_depth_keeps_float32_without_copy_and_converts_other_floats():
    a = np.ones((2, 2), np.float32)
    assert check_depth(a) is a
    for dtype in (np.float16, np.float64):
        assert check_depth(np.ones((2, 2), dtype)).dtype == np.float32


@pytest.mark.parametrize("dtype", [np.uint8, np.int8, np.uint16, np.int32, np.int64])
def test_check_depth_refuses_integer_depth(dtype):
    # One rule everywhere: integer depth is an 8-bit image, PNG codes or mm.
    with pytest.raises(TypeError, match=rf"X has integer dtype {np.dtype(dtype).name}; depth is floating-point metres"):
        check_depth(np.ones((8, 8), dtype), name="X")


@pytest.mark.parametrize("order", ["F", "strided"])
def test_check_depth_returns_c_contiguous_depth(order):
    x = np.arange(2 * 8 * 12, dtype=np.float32).reshape(2, 8, 12)
    given = np.asfortranarray(x) if order == "F" else np.repeat(x, 2, axis=2)[:, :, ::2]
    out = check_depth(given)
    assert out.flags.c_contiguous
    np.testing.assert_array_equal(out, x)


def test_check_depth_refuses_scipy_sparse():
    from scipy import sparse

    with pytest.raises(TypeError, match=r"X is a scipy.sparse csr_matrix; depth maps are dense arrays: pass X.toarray\(\)"):
        check_depth(sparse.csr_matrix(np.eye(8)), name="X")


@pytest.mark.parametrize("tiny", [1e-30, 1e-42, 5e-4, 1e-50])
def test_check_depth_refuses_depth_below_the_physical_floor(tiny):
    # 1e-42 is a float32 subnormal, 1e-50 is 0 in float32 (a float64 input is checked as given).
    x = np.full((8, 8), 10.0)
    x[0, :3] = 0.0
    x[3, 4] = tiny
    with pytest.raises(ValueError, match=rf"X has 1 pixels of positive depth below 0.001 m \(smallest {tiny:.3g} m\)"):
        check_depth(x, name="X", allow_nan=True)
    assert MIN_DEPTH == 1e-3
    x[3, 4] = MIN_DEPTH
    check_depth(x)


def test_check_depth_reports_a_float32_overflow_as_too_deep_not_infinite():
    x = np.full((8, 8), 1e39)  # float64: inf once cast to float32
    x[0, 0] = np.nan
    with pytest.raises(ValueError, match=r"X has depth up to 1e\+39 m, above 255.996 m, the most a KITTI 16-bit PNG can hold$"):
        check_depth(x, name="X", allow_nan=True)


@pytest.mark.parametrize(
    "value, error, message",
    [
        (np.ones(3), ValueError, "2-D"),
        (np.ones((0, 3)), ValueError, "empty"),
        (np.array([[1.0, np.inf]]), ValueError, "infinite"),
        (np.array([[1.0, -np.inf]]), ValueError, "infinite"),
        (np.array([[1.0, np.nan]]), ValueError, "NaN"),
        (np.array([[1.0, -2.0]]), ValueError, "negative"),
        (np.array([["a"]]), TypeError, "numeric"),
        (np.ones((2, 2), bool), TypeError, "boolean"),
    ],
)
def test_check_depth_errors(value, error, message):
    with pytest.raises(error, match=message):
        check_depth(value)


def test_check_depth_allows_nan_when_asked():
    out = check_depth(np.array([[1.0, np.nan]]), allow_nan=True)
    assert np.isnan(out[0, 1])
    # NaN fails the quick range check; the full checks still find what else is wrong.
    with pytest.raises(ValueError, match="negative"):
        check_depth(np.array([[np.nan, -1.0]]), allow_nan=True)


@pytest.mark.parametrize(
    "bad, expected",
    [(None, True), (np.nan, False), (np.inf, False), (-np.inf, False), (-1e-6, False),
     (DEPTH_LIMIT, True), (np.nextafter(np.float32(DEPTH_LIMIT), np.float32(np.inf)), False), (0.0, True)],
)
def test_in_depth_range_finds_one_bad_pixel(bad, expected):
    frame = np.full((64, 96), 10.0, np.float32)
    if bad is not None:
        frame[37, 51] = bad
    assert in_depth_range(frame) is expected


def test_check_mask():
    assert check_mask(np.array([[0, 1]]), (1, 2)).dtype == bool
    with pytest.raises(ValueError, match="shape"):
        check_mask(np.ones((2, 2), bool), (1, 2))
    with pytest.raises(TypeError):
        check_mask(np.array([["x", "y"]]), (1, 2))


@pytest.mark.parametrize("shape", [(352, 1216, 1), (8, 8, 1), (40, 64, 1)])
def test_check_depth_refuses_a_trailing_channel_axis(shape):
    # (H, W, 1) would otherwise be scored as H frames of width 1.
    with pytest.raises(ValueError, match=r"trailing size-1 axis looks like a channel axis; pass \(H, W\)"):
        check_depth(np.ones(shape), name="X")


@pytest.mark.parametrize("shape", [(4, 6), (4, 1), (1, 8, 8), (3, 8, 12), (2, 352, 1216)])
def test_check_depth_keeps_small_single_frames_and_batches_of_real_frames(shape):
    # A 2-D frame has no axis to misread; a batch's frames are at least MIN_FRAME_SIDE.
    assert check_depth(np.ones(shape)).shape == shape


@pytest.mark.parametrize("shape", [(352, 1216, 3), (352, 1216, 4), (40, 64, 3)])
def test_check_depth_refuses_a_colour_image(shape):
    # (H, W, 3) used to be read as H frames of W x 3 pixels.
    with pytest.raises(ValueError, match=rf"X has shape \({shape[0]}, {shape[1]}, {shape[2]}\): a trailing "
                                         rf"size-{shape[2]} axis looks like colour channels .*, not {shape[0]} frames"):
        check_depth(np.ones(shape), name="X", allow_nan=True)


@pytest.mark.parametrize("shape", [(3, 4, 6), (2, 1, 6), (1, 7, 64), (5, 64, 2), (10, 3, 40), (1, 1, 1), (2, 4, 1),
                                   (5, 6, 1), (1, 352, 3)])
def test_check_depth_refuses_frames_smaller_than_the_minimum(shape):
    # A 1x1 frame batched as (1, 1, 1) was refused as "a channel axis": it is too small either way.
    assert MIN_FRAME_SIDE == 8
    with pytest.raises(ValueError, match=rf"too small: read as {shape[0]} frames of {shape[1]}x{shape[2]} pixels, but a depth "
                                         r"frame in an \(N, H, W\) batch is at least 8x8"):
        check_depth(np.ones(shape))


def test_check_depth_refuses_raw_png_codes():
    raw = np.full((3, 4), 15359, dtype=np.uint16)  # 60 m stored as metres x 256
    with pytest.raises(TypeError, match=r"X has integer dtype uint16.*divide by 256"):
        check_depth(raw, name="X")
    with pytest.raises(ValueError, match=r"X has depth up to 1.536e\+04 m, above 255.996 m.*divide by 256"):
        check_depth(raw.astype(np.float32), name="X")
    # The largest encodable depth itself is fine.
    assert check_depth(np.full((2, 2), DEPTH_LIMIT)).max() == pytest.approx(DEPTH_LIMIT)


def test_check_depth_refuses_masked_arrays():
    m = np.ma.masked_array(np.ones((2, 3)), mask=[[1, 0, 0], [0, 0, 0]])
    with pytest.raises(TypeError, match="masked array; pass a plain array with 0 for no data"):
        check_depth(m)


@pytest.mark.parametrize(
    "value, error, match",
    [
        ("12", TypeError, "seeds must be distinct non-negative integers, got '12'"),
        ([0.5, 1.5], TypeError, r"got \[0.5, 1.5\]"),
        (1.7, TypeError, "got 1.7"),
        (True, TypeError, "got True"),
        (None, TypeError, "got None"),
        (np.array([0.0, 1.0]), TypeError, "seeds must be"),
        ([0, 0], ValueError, r"\[0\] repeated"),
        (-1, ValueError, "seeds must be distinct non-negative integers, got -1"),
        ([1, -2], ValueError, "non-negative"),
        ([], ValueError, "seeds is empty"),
    ],
)
def test_check_seeds_refuses_instead_of_coercing(value, error, match):
    with pytest.raises(error, match=match):
        check_seeds(value, "seeds")


def test_check_seeds_accepts_integer_kinds():
    assert check_seeds(3) == [3]
    assert check_seeds(np.int64(3)) == [3]
    assert check_seeds([np.int32(2), 0]) == [2, 0]
    assert check_seeds(range(3)) == [0, 1, 2]
    assert check_seeds(np.array([4, 1])) == [4, 1]
    assert check_seeds([1, 1], distinct=False) == [1, 1]
    assert check_seeds([], allow_empty=True) == []
    with pytest.raises(ValueError, match=r"indices \[5\] are outside 0..4"):
        check_seeds([0, 5], "indices", upper=5)


@pytest.mark.parametrize(
    "value, error", [(None, TypeError), (True, TypeError), (0.9, TypeError), ("3", TypeError), (-1, ValueError)]
)
def test_check_seed_names_the_parameter(value, error):
    with pytest.raises(error, match="mask_seed must be a non-negative integer"):
        check_seed(value, "mask_seed")


def test_check_seed_and_check_int_accept_numpy_integers():
    assert check_seed(np.uint8(4)) == 4 and type(check_seed(np.uint8(4))) is int
    assert check_int(np.int64(2), "n", minimum=1) == 2
    with pytest.raises(TypeError, match="n_frames must be an integer, got 1.5"):
        check_int(1.5, "n_frames", minimum=1)
    with pytest.raises(TypeError, match="n_frames must be an integer, got '2'"):
        check_int("2", "n_frames", minimum=1)
    with pytest.raises(ValueError, match="batch_size must be >= 1, got 0"):
        check_int(0, "batch_size", minimum=1)


@pytest.mark.parametrize(
    "value, error",
    [(float("nan"), ValueError), (float("inf"), ValueError), (0, ValueError), (-5.0, ValueError),
     ("80", TypeError), (None, TypeError), (True, TypeError)],
)
def test_check_max_depth(value, error):
    with pytest.raises(error, match="max_depth must be a finite positive number of metres, got"):
        check_max_depth(value)


def test_check_max_depth_message_shows_nan_plainly():
    with pytest.raises(ValueError, match="got nan$"):
        check_max_depth(np.float64("nan"))
    assert check_max_depth(np.float32(80)) == 80.0


def test_check_seeds_keeps_messages_short_for_long_lists():
    from inpaintenv.conventions import check_seeds

    with pytest.raises(ValueError, match=r"\.\.\. \(\d+ characters\) \(\[5\] repeated\)") as info:
        check_seeds([*range(100_000), 5], "indices")
    assert len(str(info.value)) < 300
