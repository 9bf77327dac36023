"""FLOPs and parameters of the study's U-Net, counted on the meta device or from its architecture.

``FlopCounterMode`` counts the matrix-multiply-like operators (every convolution and its two
backward products, 2 FLOPs per multiply-add, biases excluded) without running any arithmetic,
so any resolution is free to count; :func:`unet_conv_flops` gives the same number from the
architecture alone. Shared by ``scaling_training.py`` and ``gpu_check.py``'s tests; not run
by itself.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import torch
from torch.utils.flop_counter import FlopCounterMode

from estimators.learned.nets import UNet


def count_flops(fn: Callable[[], Any]) -> int:
    """FLOPs of the matmul-like operators run by ``fn()`` (``FlopCounterMode`` total).

    Parameters
    ----------
    fn : callable
        Runs the computation to count (forward, or forward + backward).

    Returns
    -------
    int
        2 × multiply-adds of every convolution / matrix product, biases excluded.
    """
    with FlopCounterMode(display=False) as counter:
        fn()
    return int(counter.get_total_flops())


def _meta_unet(width: int, depth: int, skip: bool = True) -> UNet:
    with torch.device("meta"):
        return UNet(1, width, depth, skip=skip)


def forward_flops(width: int, depth: int, height: int, width_px: int, batch: int = 1, skip: bool = True) -> int:
    """Counted FLOPs of one UNet forward on ``(batch, 1, height, width_px)`` (meta device)."""
    model = _meta_unet(width, depth, skip)
    x = torch.empty(batch, 1, height, width_px, device="meta")
    return count_flops(lambda: model(x))


def train_flops(width: int, depth: int, height: int, width_px: int, batch: int = 1, skip: bool = True) -> int:
    """Counted FLOPs of forward + backward of one UNet training step (meta device).

    The input does not require a gradient (as in training), so the first convolution's
    input gradient is not computed.
    """
    model = _meta_unet(width, depth, skip)
    x = torch.empty(batch, 1, height, width_px, device="meta")
    return count_flops(lambda: model(x).sum().backward())


def unet_level_flops(
    width: int, depth: int, height: int, width_px: int, batch: int = 1, in_channels: int = 1,
    skip: bool = True,
) -> list[int]:
    """Forward convolution FLOPs of each resolution level of the UNet (encoder + decoder block).

    ``2 × 9 × c_in × c_out`` per output pixel and 3×3 convolution; the input is padded
    to a multiple of ``2**depth`` first, as the network does. Finest level first; the
    1×1 head is not included (see :func:`unet_conv_flops`).
    """
    mult = 2**depth
    h, w = -(-height // mult) * mult, -(-width_px // mult) * mult
    ch = [width * 2**level for level in range(depth + 1)]
    levels = []
    for level in range(depth + 1):
        pixels = (h >> level) * (w >> level)
        c_in = in_channels if level == 0 else ch[level - 1]
        flops = pixels * 18 * (c_in * ch[level] + ch[level] * ch[level])        # encoder
        if level < depth:
            c_in = ch[level + 1] + (ch[level] if skip else 0)
            flops += pixels * 18 * (c_in * ch[level] + ch[level] * ch[level])    # decoder
        levels.append(batch * flops)
    return levels


def unet_conv_flops(
    width: int, depth: int, height: int, width_px: int, batch: int = 1, in_channels: int = 1,
    skip: bool = True,
) -> int:
    """Forward convolution FLOPs of :class:`estimators.learned.nets.UNet` from its architecture.

    The levels of :func:`unet_level_flops` plus ``2 × width`` per pixel for the 1×1 head.

    Returns
    -------
    int
        Equal to :func:`forward_flops` (tested).
    """
    mult = 2**depth
    h, w = -(-height // mult) * mult, -(-width_px // mult) * mult
    head = batch * h * w * 2 * width
    return sum(unet_level_flops(width, depth, height, width_px, batch, in_channels, skip)) + head


def n_params(width: int, depth: int, skip: bool = True) -> int:
    """Trainable parameters of ``UNet(1, width, depth, skip)``."""
    return sum(p.numel() for p in _meta_unet(width, depth, skip).parameters())
