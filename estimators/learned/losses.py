r"""The study's training loss (eq. 3-6): L1 on valid pixels + λ·L1 in the holes + β·TV.

With prediction :math:`p`, ground truth :math:`g` (both normalised by ``max_depth``),
valid set :math:`S = \{g > 0\}` and hole set :math:`H`, over a whole batch:

.. math::

    L_{valid} = \frac{1}{|S|} \sum_{i \in S} |p_i - g_i|, \qquad
    L_{hole}  = \frac{1}{|S \cap H|} \sum_{i \in S \cap H} |p_i - g_i|,

    L_{TV} = \frac{1}{N H (W-1)} \sum |p_{y,x+1} - p_{y,x}|
           + \frac{1}{N (H-1) W} \sum |p_{y+1,x} - p_{y,x}|,

    L = L_{valid} + \lambda L_{hole} + \beta L_{TV}.

Normalisation: each mean is pooled over the batch (every pixel of the batch weighs the
same, not every frame); the two TV directions are averaged over their own numbers of
neighbour pairs and summed (anisotropic TV over all predicted pixels). An empty pixel
set (no valid ground truth, no hole, or a 1-pixel-wide image for TV) gives a term of
0 with zero gradient, never NaN.

All functions take ``(N, 1, H, W)`` or ``(N, H, W)`` tensors; masks are boolean.
"""

from __future__ import annotations

import torch

from inpaintenv.exceptions import InvalidInputError

__all__ = ["hole_l1", "inpainting_loss", "masked_l1", "total_variation", "valid_l1"]


def _check(pred: torch.Tensor, target: torch.Tensor, *masks: torch.Tensor) -> None:
    for name, t in (("target", target), *((f"mask {k}", m) for k, m in enumerate(masks))):
        if t.shape != pred.shape:
            raise ValueError(f"{name} has shape {tuple(t.shape)}, prediction {tuple(pred.shape)}")
    for k, m in enumerate(masks):
        if m.dtype != torch.bool:
            raise TypeError(f"mask {k} must be a bool tensor, got {m.dtype}")


def masked_l1(pred: torch.Tensor, target: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    """Mean absolute error over the pixels where ``mask`` is True (0 if there are none).

    Parameters
    ----------
    pred, target : torch.Tensor
        Same shape.
    mask : torch.Tensor
        Bool, same shape.

    Returns
    -------
    torch.Tensor
        0-d tensor in ``pred``'s units and dtype (float32 at least).
    """
    _check(pred, target, mask)
    err = (pred.float() - target.float()).abs()
    # where() rather than multiply: a NaN/inf target outside the mask must not leak in.
    total = torch.where(mask, err, torch.zeros_like(err)).sum()
    return total / mask.sum().clamp(min=1)


def valid_l1(pred: torch.Tensor, target: torch.Tensor, valid: torch.Tensor) -> torch.Tensor:
    """:math:`L_{valid}`: L1 over pixels with ground truth (eq. 3)."""
    return masked_l1(pred, target, valid)


def hole_l1(
    pred: torch.Tensor, target: torch.Tensor, valid: torch.Tensor, hole: torch.Tensor
) -> torch.Tensor:
    """:math:`L_{hole}`: L1 over pixels with ground truth inside the holes (eq. 4)."""
    _check(pred, target, valid, hole)
    return masked_l1(pred, target, valid & hole)


def total_variation(pred: torch.Tensor) -> torch.Tensor:
    """:math:`L_{TV}`: anisotropic total variation of the prediction (eq. 5).

    Mean absolute horizontal neighbour difference plus mean absolute vertical one.
    """
    if pred.ndim < 2:
        raise ValueError(f"total_variation needs at least 2-D input, got {tuple(pred.shape)}")
    p = pred.float()
    zero = p.sum() * 0.0  # keeps the graph and device when a direction is empty
    dx = (p[..., :, 1:] - p[..., :, :-1]).abs()
    dy = (p[..., 1:, :] - p[..., :-1, :]).abs()
    tv_x = dx.mean() if dx.numel() else zero
    tv_y = dy.mean() if dy.numel() else zero
    return tv_x + tv_y


def inpainting_loss(
    pred: torch.Tensor,
    target: torch.Tensor,
    valid: torch.Tensor,
    hole: torch.Tensor,
    hole_weight: float = 2.0,
    tv_weight: float = 0.01,
    *,
    return_terms: bool = False,
) -> torch.Tensor | tuple[torch.Tensor, dict[str, torch.Tensor]]:
    """The study's loss :math:`L = L_{valid} + λ L_{hole} + β L_{TV}` (eq. 6).

    Parameters
    ----------
    pred, target : torch.Tensor
        Prediction and ground truth, same shape and units (normalised depth).
    valid : torch.Tensor
        Bool, True where the ground truth has a measurement.
    hole : torch.Tensor
        Bool, True inside the occlusion.
    hole_weight : float
        λ, default 2.0.
    tv_weight : float
        β, default 0.01.
    return_terms : bool
        Also return the detached terms ``{"valid", "hole", "tv"}``.

    Returns
    -------
    torch.Tensor or (torch.Tensor, dict)
    """
    if hole_weight < 0 or tv_weight < 0:
        raise InvalidInputError(f"loss weights must be >= 0, got hole_weight={hole_weight}, tv_weight={tv_weight}")
    _check(pred, target, valid, hole)
    l_valid = valid_l1(pred, target, valid)
    l_hole = hole_l1(pred, target, valid, hole)
    l_tv = total_variation(pred)
    loss = l_valid + hole_weight * l_hole + tv_weight * l_tv
    if return_terms:
        return loss, {"valid": l_valid.detach(), "hole": l_hole.detach(), "tv": l_tv.detach()}
    return loss
