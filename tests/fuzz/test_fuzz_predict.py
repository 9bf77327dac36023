"""BaseInpainter.predict input validation on random arrays, through cheap classical methods.

Any input either raises the documented ``TypeError`` (not a floating-point array) or
``ValueError`` (wrong ndim, a channel axis or frames below MIN_FRAME_SIDE, empty, inf, negative, no NaN to fill), or gives float32
depth of the input's shape, finite and non-negative, with measured pixels kept.
"""

from __future__ import annotations

import numpy as np
import pytest
from fuzz_settings import fast
from hypothesis import given
from hypothesis import strategies as st

from estimators.classical import ConstantInpainter, NearestInpainter, TeleaInpainter
from inpaintenv.conventions import MIN_FRAME_SIDE

ESTIMATORS = [NearestInpainter, ConstantInpainter, TeleaInpainter]
NUMERIC = [np.float16, np.float32, np.float64, np.int8, np.int16, np.int32, np.int64, np.uint8, np.uint16]
OTHER = [np.bool_, np.complex64, np.object_, np.str_]


@st.composite
def inputs(draw):
    ndim = draw(st.sampled_from([0, 1, 2, 2, 3, 3, 4]))
    # Sides up to 10 so 3-D batches fall on both sides of MIN_FRAME_SIDE (8).
    shape = tuple(draw(st.integers(0 if ndim and draw(st.booleans()) else 1, 10)) for _ in range(ndim))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    x = rng.uniform(0.5, 80.0, shape)
    x[rng.random(shape) < draw(st.sampled_from([0.0, 0.5, 1.0]))] = 0.0  # 1.0: all-zero map
    if draw(st.booleans()):
        x[rng.random(shape) < draw(st.sampled_from([0.2, 1.0]))] = np.nan  # 1.0: nothing observed
    if x.size and draw(st.booleans()):
        x.reshape(-1)[rng.integers(x.size)] = draw(st.sampled_from([np.inf, -np.inf, -2.0]))
    dtype = draw(st.sampled_from(NUMERIC + OTHER))
    with np.errstate(invalid="ignore"):
        arr = x.astype(dtype) if dtype is not np.str_ else x.astype(str)
    return arr


def expected_error(x: np.ndarray) -> type[Exception] | None:
    # Depth is floating point everywhere: integers (an 8-bit image, PNG codes) are refused too.
    if not np.issubdtype(x.dtype, np.floating):
        return TypeError
    if x.ndim not in (2, 3) or x.size == 0:
        return ValueError
    # (H, W, 1/3/4) reads as a channel axis, and a batch's frames are at least MIN_FRAME_SIDE: refused
    if x.ndim == 3 and (x.shape[-1] in (1, 3, 4) or min(x.shape[1:]) < MIN_FRAME_SIDE):
        return ValueError
    f = x.astype(np.float64)
    if np.isinf(f).any() or (f < 0).any() or not np.isnan(f).any():
        return ValueError
    return None


@pytest.mark.parametrize("estimator", ESTIMATORS, ids=lambda c: c.__name__)
@fast(40)
@given(x=inputs())
def test_predict_raises_a_documented_error_or_fills_every_pixel(estimator, x):
    want = expected_error(x)
    before = x.copy()
    if want is not None:
        with pytest.raises(want):
            estimator().predict(x)
        return
    out = estimator().predict(x)
    assert out.dtype == np.float32 and out.shape == x.shape
    assert np.isfinite(out).all() and (out >= 0).all()
    observed = x.astype(np.float32) > 0
    np.testing.assert_array_equal(out[observed], x.astype(np.float32)[observed])
    np.testing.assert_array_equal(x, before)  # the input is never modified
