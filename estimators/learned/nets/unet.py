"""The study's U-Net and its no-skip autoencoder ablation, split into encoder and decoder.

Layout for ``width=w``, ``depth=d`` (``d`` 2×-downsamplings, ``d + 1`` resolution levels)::

    level l (l = 0..d):  ConvBlock -> w·2**l channels, then MaxPool2d(2) unless l == d
    decoder l = d-1..0: bilinear ×2 upsample, concat the level-l encoder feature
                        (U-Net only), ConvBlock -> w·2**l channels
    head:               1×1 convolution -> 1 channel

A :class:`ConvBlock` is ``(3×3 conv -> GroupNorm -> ReLU) × 2``. Inputs of any size
work: :class:`UNet` pads the bottom/right edge to a multiple of ``2**d`` and crops back.

Sizes are taken as given (positive integers): the estimators check their parameters
(:mod:`estimators._constraints`) and the size limits before they build a network.
"""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F
from torch import nn

from inpaintenv.exceptions import InvalidInputError

__all__ = ["ConvBlock", "UNet", "UNetDecoder", "UNetEncoder", "pad_to_multiple"]

#: GroupNorm uses this many groups, or gcd(channels, GROUPS) for narrow layers.
GROUPS = 8
PAD_MODES = ("replicate", "zeros")


def _norm(channels: int) -> nn.GroupNorm:
    return nn.GroupNorm(math.gcd(channels, GROUPS), channels)


class ConvBlock(nn.Sequential):
    """Two 3×3 convolutions, each followed by GroupNorm and ReLU.

    Parameters
    ----------
    in_channels, out_channels : int
    """

    def __init__(self, in_channels: int, out_channels: int):
        super().__init__(
            nn.Conv2d(in_channels, out_channels, 3, padding=1),
            _norm(out_channels),
            nn.ReLU(inplace=True),
            nn.Conv2d(out_channels, out_channels, 3, padding=1),
            _norm(out_channels),
            nn.ReLU(inplace=True),
        )


class UNetEncoder(nn.Module):
    """Contracting path: ``depth + 1`` conv blocks with max-pooling between them.

    Parameters
    ----------
    in_channels : int
    width : int
        Channels of the first level; level ``l`` has ``width * 2**l``.
    depth : int
        Number of 2× downsamplings.
    """

    def __init__(self, in_channels: int, width: int, depth: int):
        super().__init__()
        self.channels = [width * 2**level for level in range(depth + 1)]
        ins = [in_channels, *self.channels[:-1]]
        self.blocks = nn.ModuleList(ConvBlock(i, o) for i, o in zip(ins, self.channels))
        self.pool = nn.MaxPool2d(2)

    def forward(self, x: torch.Tensor) -> list[torch.Tensor]:
        """Return the feature of every level, finest first (the last is the bottleneck)."""
        features = []
        for level, block in enumerate(self.blocks):
            if level:
                x = self.pool(x)
            x = block(x)
            features.append(x)
        return features


class UNetDecoder(nn.Module):
    """Expanding path: bilinear upsampling, optional skip concatenation, conv block.

    Parameters
    ----------
    width, depth : int
        As in :class:`UNetEncoder`.
    skip : bool
        Concatenate the encoder feature of each level (U-Net) or not (autoencoder).
    """

    def __init__(self, width: int, depth: int, skip: bool = True):
        super().__init__()
        self.skip = bool(skip)
        channels = [width * 2**level for level in range(depth + 1)]
        # blocks[l] produces level l from level l + 1.
        self.blocks = nn.ModuleList(
            ConvBlock(channels[level + 1] + (channels[level] if self.skip else 0), channels[level])
            for level in range(depth)
        )

    def forward(self, features: list[torch.Tensor]) -> torch.Tensor:
        x = features[-1]
        for level in range(len(self.blocks) - 1, -1, -1):
            x = F.interpolate(x, scale_factor=2.0, mode="bilinear", align_corners=False)
            if self.skip:
                x = torch.cat([x, features[level]], dim=1)
            x = self.blocks[level](x)
        return x


def pad_to_multiple(x: torch.Tensor, multiple: int, mode: str = "replicate") -> torch.Tensor:
    """Pad the bottom and right of an ``(N, C, H, W)`` tensor to multiples of ``multiple``."""
    if mode not in PAD_MODES:
        raise InvalidInputError(f"pad mode must be one of {PAD_MODES}, got {mode!r}")
    h, w = x.shape[-2:]
    ph, pw = (-h) % multiple, (-w) % multiple
    if not (ph or pw):
        return x
    if mode == "zeros":
        return F.pad(x, (0, pw, 0, ph))
    # Replicate padding needs pad < size per call on some backends; repeat for tiny inputs.
    while ph or pw:
        step_h, step_w = min(ph, x.shape[-2] - 1 or 1), min(pw, x.shape[-1] - 1 or 1)
        x = F.pad(x, (0, step_w, 0, step_h), mode="replicate")
        ph, pw = ph - step_h, pw - step_w
    return x


class UNet(nn.Module):
    """The study's U-Net (``skip=True``) or its autoencoder ablation (``skip=False``).

    Parameters
    ----------
    in_channels : int
        1 for the study's input (corrupted depth), 3 with hole and validity masks.
    width : int
        Channels of the first level (doubles per level).
    depth : int
        Number of 2× downsamplings; inputs are padded to a multiple of ``2**depth``.
    skip : bool
        Skip connections between encoder and decoder.
    pad_mode : {"replicate", "zeros"}
        How the internal padding is filled.

    Notes
    -----
    Input ``(N, in_channels, H, W)`` of any ``H, W >= 1``; output ``(N, 1, H, W)``.
    """

    def __init__(
        self, in_channels: int = 1, width: int = 32, depth: int = 4, skip: bool = True,
        pad_mode: str = "replicate",
    ):
        super().__init__()
        if pad_mode not in PAD_MODES:
            raise InvalidInputError(f"pad_mode must be one of {PAD_MODES}, got {pad_mode!r}")
        self.in_channels, self.width, self.depth, self.skip = in_channels, width, depth, skip
        self.pad_mode = pad_mode
        self.encoder = UNetEncoder(in_channels, width, depth)
        self.decoder = UNetDecoder(width, depth, skip=skip)
        self.head = nn.Conv2d(width, 1, 1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        if x.ndim != 4 or x.shape[1] != self.in_channels:
            raise InvalidInputError(
                f"expected input (N, {self.in_channels}, H, W), got {tuple(x.shape)}"
            )
        h, w = x.shape[-2:]
        x = pad_to_multiple(x, 2**self.depth, self.pad_mode)
        out = self.head(self.decoder(self.encoder(x)))
        return out[..., :h, :w]
