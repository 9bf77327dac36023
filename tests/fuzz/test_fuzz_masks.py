"""Every registered protocol on random shapes and seeds: bool, right shape, deterministic."""

from __future__ import annotations

import numpy as np
import pytest
from fuzz_settings import fast
from hypothesis import given
from hypothesis import strategies as st

from inpaintenv.masks import available_protocols, get_protocol

shapes = st.tuples(st.integers(1, 96), st.integers(1, 160))
seeds = st.integers(0, 2**31 - 1)
indices = st.integers(0, 10**6)


@pytest.mark.parametrize("name", available_protocols())
@fast(12)
@given(shape=shapes, seed=seeds, index=indices)
def test_mask_is_bool_of_the_shape_and_deterministic(name, shape, seed, index):
    proto = get_protocol(name)
    try:
        hole = proto.mask(shape, seed, index)
    except ValueError as exc:
        # Documented: a frame too small for the protocol's geometry is refused clearly.
        assert f"{shape[0]}x{shape[1]}" in str(exc), exc
        return
    assert hole.dtype == np.bool_ and hole.shape == shape
    np.testing.assert_array_equal(get_protocol(name).mask(shape, seed, index), hole)
    # Batched and single draws agree, whatever else is in the batch.
    np.testing.assert_array_equal(proto.masks(shape, seed, [index + 1, index])[1], hole)


@pytest.mark.parametrize("name", available_protocols())
@fast(8)
@given(
    shape=st.one_of(
        st.tuples(st.integers(-5, 0), st.integers(1, 9)),
        st.tuples(st.integers(1, 9)),
        st.tuples(st.floats(1, 9), st.integers(1, 9)),
        st.tuples(st.integers(1, 9), st.integers(1, 9), st.integers(1, 9)),
    ),
    seed=st.integers(-(2**31), -1),
)
def test_bad_shapes_and_seeds_are_value_errors(name, shape, seed):
    proto = get_protocol(name)
    with pytest.raises(ValueError, match="shape"):
        proto.mask(shape, 0, 0)
    with pytest.raises(ValueError, match="non-negative"):
        proto.mask((64, 64), seed, 0)
    with pytest.raises(ValueError, match="non-negative"):
        proto.mask((64, 64), 0, seed)
