"""Each loss term against values computed by hand on tiny tensors."""

from __future__ import annotations

import math

import pytest
import torch

from estimators.learned.losses import (
    hole_l1,
    inpainting_loss,
    masked_l1,
    total_variation,
    valid_l1,
)

# One 2×3 frame (N=1). Errors |pred - target| = [[1, 2, 3], [4, 5, 6]].
PRED = torch.tensor([[[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]])
TARGET = torch.zeros(1, 2, 3)
VALID = torch.tensor([[[True, True, False], [True, False, True]]])  # errors 1, 2, 4, 6
HOLE = torch.tensor([[[False, True, True], [False, False, True]]])  # valid ∩ hole: 2, 6


def test_valid_l1_by_hand():
    assert valid_l1(PRED, TARGET, VALID).item() == pytest.approx((1 + 2 + 4 + 6) / 4)


def test_hole_l1_by_hand():
    assert hole_l1(PRED, TARGET, VALID, HOLE).item() == pytest.approx((2 + 6) / 2)


def test_total_variation_by_hand():
    # Horizontal pairs: |2-1|,|3-2|,|5-4|,|6-5| -> mean 1; vertical: |4-1|,|5-2|,|6-3| -> mean 3.
    assert total_variation(PRED).item() == pytest.approx(1.0 + 3.0)


def test_total_loss_combines_terms_with_weights():
    loss, terms = inpainting_loss(PRED, TARGET, VALID, HOLE, hole_weight=2.0, tv_weight=0.5, return_terms=True)
    assert loss.item() == pytest.approx(13 / 4 + 2.0 * 4.0 + 0.5 * 4.0)
    assert {k: v.item() for k, v in terms.items()} == pytest.approx({"valid": 13 / 4, "hole": 4.0, "tv": 4.0})
    default = inpainting_loss(PRED, TARGET, VALID, HOLE)
    assert default.item() == pytest.approx(13 / 4 + 2.0 * 4.0 + 0.01 * 4.0)


def test_means_are_pooled_over_the_batch():
    pred = torch.stack([PRED[0], torch.full((2, 3), 10.0)])
    valid = torch.stack([VALID[0], torch.tensor([[True, False, False], [False, False, False]])])
    # Pixels 1, 2, 4, 6 from frame 0 and 10 from frame 1 weigh the same.
    assert valid_l1(pred, torch.zeros_like(pred), valid).item() == pytest.approx((1 + 2 + 4 + 6 + 10) / 5)


def test_empty_sets_give_zero_not_nan_and_zero_gradient():
    pred = PRED.clone().requires_grad_(True)
    none = torch.zeros_like(VALID)
    h = hole_l1(pred, TARGET, VALID, none)
    v = valid_l1(pred, TARGET, none)
    assert h.item() == 0.0 and v.item() == 0.0
    (h + v).backward()
    assert torch.equal(pred.grad, torch.zeros_like(pred))
    # A 1×1 image has no neighbour pairs.
    assert total_variation(torch.ones(1, 1, 1)).item() == 0.0
    loss = inpainting_loss(PRED, TARGET, none, none)
    assert not math.isnan(loss.item())


def test_nan_target_outside_the_mask_does_not_leak():
    target = TARGET.clone()
    target[~VALID] = float("nan")
    assert masked_l1(PRED, target, VALID).item() == pytest.approx(13 / 4)


def test_gradient_of_hole_term_by_hand():
    pred = PRED.clone().requires_grad_(True)
    hole_l1(pred, TARGET, VALID, HOLE).backward()
    expected = torch.where(VALID & HOLE, torch.tensor(0.5), torch.tensor(0.0))
    assert torch.allclose(pred.grad, expected)


def test_bad_inputs_are_named():
    with pytest.raises(ValueError, match="shape"):
        valid_l1(PRED, torch.zeros(1, 3, 2), VALID)
    with pytest.raises(TypeError, match="bool"):
        valid_l1(PRED, TARGET, VALID.float())
    with pytest.raises(ValueError, match=">= 0"):
        inpainting_loss(PRED, TARGET, VALID, HOLE, hole_weight=-1.0)
