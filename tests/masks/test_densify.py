"""``densify-v1``: the protocol with no hole (fill every pixel the input did not measure)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from inpaintenv.masks import DensifyV1, available_protocols, get_protocol, mask_rng


def test_registered_and_described():
    proto = get_protocol("densify-v1")
    assert isinstance(proto, DensifyV1) and "densify-v1" in available_protocols()
    desc = json.loads(json.dumps(proto.describe()))
    assert desc["name"] == "densify-v1" and desc["hole_fraction_range"] == [0.0, 0.0] and desc["description"]
    # Its headline metric is unmeasured_rmse; every other protocol's is hole_rmse.
    assert proto.task == "unmeasured" and get_protocol("rect-v1").task == "hole"


def test_no_hole_for_any_seed_or_frame():
    proto = get_protocol("densify-v1")
    masks = proto.masks((40, 96), seed=3, indices=[0, 1, 7])
    assert masks.dtype == np.bool_ and masks.shape == (3, 40, 96) and not masks.any()
    np.testing.assert_array_equal(proto.sample((40, 96), mask_rng("densify-v1", 3, 7)), masks[2])


@pytest.mark.parametrize("shape, seed, error", [((0, 8), 0, ValueError), ((8, 8), -1, ValueError),
                                                ((8, 8), 0.5, TypeError)])
def test_bad_arguments_are_refused_like_every_protocol(shape, seed, error):
    with pytest.raises(error):
        get_protocol("densify-v1").mask(shape, seed=seed, index=0)
