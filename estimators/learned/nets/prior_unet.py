"""A CPU-sized U-Net that blends classical candidate fills and adds a residual.

Layout (``factor=f``, ``width=w``, ``levels=L``)::

    input  (N, 3 + K, H, W): depth, hole, valid, K candidate fills (metres)
           + a row-coordinate channel (depth statistics change with image row)
    pixel-unshuffle ×f       -> (N, (4 + K)·f², H/f, W/f)      the network runs at 1/f
    1×1 conv "patch embed"   -> w channels
    U-Net, L 2×-downsamplings, (3×3 conv -> GroupNorm -> ReLU)×2 per level
    1×1 head, pixel-shuffle ×f -> (N, K + 1, H, W)
    output = Σ_k softmax(logits)_k · candidate_k + residual      (metres)

The head starts at zero, so an untrained model returns the mean of the candidates.
Working at 1/f resolution is what makes training affordable on 2 CPU cores; the
full-resolution candidates keep the detail.

Sizes are taken as given (positive integers): the estimators check their parameters
(:mod:`estimators._constraints`) and the size limits before they build a network.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn

from .unet import ConvBlock, pad_to_multiple

__all__ = ["PriorUNet"]

#: Depth scale of the network's inputs and residual (metres).
DEPTH_SCALE = 80.0


class PriorUNet(nn.Module):
    """Blend of candidate fills plus a residual, predicted at reduced resolution.

    Parameters
    ----------
    n_candidates : int
        Number of candidate fill channels ``K`` after depth, hole and valid.
    width : int
        Channels of the first level (doubled per level).
    levels : int
        Number of 2× downsamplings after the pixel-unshuffle.
    factor : int
        Pixel-unshuffle factor: the network runs at ``1/factor`` resolution.

    Notes
    -----
    Input ``(N, 3 + K, H, W)`` of any size (padded internally to a multiple of
    ``factor · 2**levels``, replicate, and cropped back); output ``(N, H, W)`` metres.
    """

    def __init__(self, n_candidates: int = 4, width: int = 32, levels: int = 3, factor: int = 8):
        super().__init__()
        self.n_candidates, self.width, self.levels, self.factor = n_candidates, width, levels, factor
        in_channels = (4 + n_candidates) * factor * factor
        channels = [width * 2**level for level in range(levels + 1)]
        self.stem = nn.Sequential(nn.Conv2d(in_channels, width, 1), nn.ReLU(inplace=True))
        self.encoder = nn.ModuleList(
            ConvBlock(i, o) for i, o in zip([width, *channels[:-1]], channels)
        )
        self.decoder = nn.ModuleList(
            ConvBlock(channels[level + 1] + channels[level], channels[level]) for level in range(levels)
        )
        self.head = nn.Conv2d(width, (n_candidates + 1) * factor * factor, 1)
        # Zero head: the untrained model is the plain mean of the candidates.
        nn.init.zeros_(self.head.weight)
        nn.init.zeros_(self.head.bias)

    @property
    def in_channels(self) -> int:
        """Expected input channels ``3 + K``."""
        return 3 + self.n_candidates

    def forward(self, x: torch.Tensor, where: torch.Tensor | None = None) -> torch.Tensor:
        """``(N, 3 + K, H, W)`` -> ``(N, H, W)`` metres, or ``(P,)`` at ``where`` if given."""
        if where is not None:
            return self.forward(x)[where]
        if x.ndim != 4 or x.shape[1] != self.in_channels:
            raise ValueError(f"expected input (N, {self.in_channels}, H, W), got {tuple(x.shape)}")
        n, _, h, w = x.shape
        x = pad_to_multiple(x, self.factor * 2**self.levels)
        hp, wp = x.shape[-2:]
        candidates = x[:, 3:]
        rows = torch.linspace(0.0, 1.0, hp, device=x.device, dtype=x.dtype).view(1, 1, hp, 1).expand(n, 1, hp, wp)
        z = torch.cat([x[:, :1] / DEPTH_SCALE, x[:, 1:3], candidates / DEPTH_SCALE, rows], dim=1)
        z = self.stem(F.pixel_unshuffle(z, self.factor))
        features = []
        for level, block in enumerate(self.encoder):
            if level:
                z = F.max_pool2d(z, 2)
            z = block(z)
            features.append(z)
        for level in range(self.levels - 1, -1, -1):
            z = F.interpolate(z, size=features[level].shape[-2:], mode="bilinear", align_corners=False)
            z = self.decoder[level](torch.cat([z, features[level]], dim=1))
        out = F.pixel_shuffle(self.head(z), self.factor)
        weights = torch.softmax(out[:, : self.n_candidates], dim=1)
        pred = (weights * candidates).sum(dim=1) + DEPTH_SCALE * out[:, self.n_candidates]
        return pred[:, :h, :w]

    def extra_repr(self) -> str:
        return f"n_candidates={self.n_candidates}, width={self.width}, levels={self.levels}, factor={self.factor}"
