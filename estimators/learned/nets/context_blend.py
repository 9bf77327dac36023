"""Scene context for the per-pixel blend: a small U-Net over the whole frame at 1/8 scale.

The per-pixel blend (:class:`~estimators.learned.nets.pixel_blend.PixelBlendNet`) sees what lies
on the four axis lines through a pixel. What a large hole hides also depends on the
scene around it: where the road and the far scene are, how deep the frame is on the
other side of the hole. :class:`ContextUNet` reads a coarse, scale-free summary of the
whole frame (:func:`context_grid`) and gives every pixel ``n_context`` features, which
the per-pixel MLP reads beside its own (plus how far the pixel's candidates lie from
the frame's median depth). Both are trained together.

Layout of :class:`ContextUNet` with ``widths=(w0, ..., wd)`` on the context grid::

    level l:  (3x3 conv -> GroupNorm -> ReLU) x 2 -> w_l channels, then 2x2 average pool
    decoder:  bilinear upsample, concat level l, the same block -> w_l channels
    head:     1x1 convolution -> n_context channels

Everything is relative to the frame's median log-depth, so the model is scale-free like
the blend: a frame twice as deep gets a prediction twice as deep.

Sizes are taken as given (positive integers): the estimators check their parameters
(:mod:`estimators._constraints`) and the size limits before they build a network.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import cv2
import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from inpaintenv.exceptions import InvalidInputError

from .pixel_blend import MIN_DEPTH, PixelBlendNet

__all__ = ["CELL", "ContextBlendEnsemble", "ContextBlendNet", "ContextUNet", "context_grid", "frame_reference"]

#: Pixels per side of a context cell: block means over 4x4 pixels, then over 2x2 blocks.
CELL = 8
_BLOCK = 4
#: Context channels before the candidates: observed log-depth, density, hole fraction.
GRID_BASE_CHANNELS = ("observed", "density", "hole")
#: GroupNorm groups (or gcd with the channels for narrow layers).
_GROUPS = 4


def frame_reference(x: np.ndarray) -> float:
    """Median log-depth (log metres) of the measured pixels of ``x``; log 10 m if none."""
    known = x > 0  # NaN > 0 is False
    return float(np.median(np.log(x[known]))) if known.any() else float(np.log(10.0))


def _block_sum(a: np.ndarray, block: int) -> np.ndarray:
    """Sums over ``block`` x ``block`` pixel blocks of ``(..., H, W)``, zero-padded at the bottom/right.

    OpenCV's area resize gives the block means (10x faster than a NumPy reshape-sum at
    KITTI size); the padding keeps the sums exact for any frame size.
    """
    h, w = a.shape[-2:]
    ph, pw = (-h) % block, (-w) % block
    if ph or pw:
        a = np.pad(a, [(0, 0)] * (a.ndim - 2) + [(0, ph), (0, pw)])
    size = ((w + pw) // block, (h + ph) // block)
    flat = np.ascontiguousarray(a, np.float32).reshape(-1, h + ph, w + pw)
    means = np.stack([cv2.resize(c, size, interpolation=cv2.INTER_AREA) for c in flat])
    return (means * float(block * block)).reshape(*a.shape[:-2], size[1], size[0])


def context_grid(x: np.ndarray, candidates: np.ndarray, ref: float | None = None) -> np.ndarray:
    """Coarse, scale-free summary of one corrupted frame for :class:`ContextUNet`.

    Parameters
    ----------
    x : numpy.ndarray
        ``(H, W)`` metres; NaN = hole, 0 = no measurement.
    candidates : numpy.ndarray
        ``(K, H, W)`` candidate fills of ``x`` (metres).
    ref : float, optional
        Reference log-depth (default :func:`frame_reference` of ``x``).

    Returns
    -------
    numpy.ndarray
        ``(3 + K, ceil(ceil(H/4)/2), ceil(ceil(W/4)/2))`` float32: per cell the mean
        observed log-depth relative to ``ref`` (0 where nothing is measured), the
        measured fraction, the hole fraction and each candidate's mean log-depth
        relative to ``ref``. Means are taken over 4x4-pixel blocks, then over 2x2
        blocks (cells of :data:`CELL` pixels).
    """
    h, w = x.shape
    ref = frame_reference(x) if ref is None else float(ref)
    known = x > 0
    count = _block_sum(known.astype(np.float32), _BLOCK)
    logs = np.zeros((h, w), np.float32)
    logs[known] = np.log(x[known]) - ref
    observed = np.divide(_block_sum(logs, _BLOCK), count, out=np.zeros_like(count), where=count > 0)
    area = _block_sum(np.ones((h, w), np.float32), _BLOCK)
    hole = _block_sum(np.isnan(x).astype(np.float32), _BLOCK) / area
    # cv2.log: 6x faster than np.log on full frames of candidates
    log_c = np.stack([cv2.log(np.maximum(c, MIN_DEPTH, dtype=np.float32)) for c in candidates]) - np.float32(ref)
    cands = _block_sum(log_c, _BLOCK) / area
    fine = np.concatenate([np.stack([observed, count / area, hole]), cands]).astype(np.float32)
    # 2x2 mean of the 4x4 blocks (over the blocks that exist at the bottom/right edge)
    ones = _block_sum(np.ones(fine.shape[-2:], np.float32), 2)
    return (_block_sum(fine, 2) / ones).astype(np.float32)


def _block(a: int, b: int) -> nn.Sequential:
    return nn.Sequential(
        nn.Conv2d(a, b, 3, padding=1), nn.GroupNorm(math.gcd(b, _GROUPS), b), nn.ReLU(inplace=True),
        nn.Conv2d(b, b, 3, padding=1), nn.GroupNorm(math.gcd(b, _GROUPS), b), nn.ReLU(inplace=True),
    )


class ContextUNet(nn.Module):
    """U-Net from a context grid to ``out_channels`` features per cell (any grid size).

    Parameters
    ----------
    in_channels, out_channels : int
    widths : sequence of int
        Channels per level; ``len(widths) - 1`` average-pool downsamplings.
    """

    def __init__(self, in_channels: int, out_channels: int, widths: Sequence[int] = (16, 32, 48, 64)):
        super().__init__()
        widths = tuple(widths)
        self.widths = widths
        self.down = nn.ModuleList()
        prev = in_channels
        for w in widths:
            self.down.append(_block(prev, w))
            prev = w
        self.up = nn.ModuleList(_block(widths[i + 1] + widths[i], widths[i]) for i in range(len(widths) - 1))
        self.head = nn.Conv2d(widths[0], out_channels, 1)

    def forward(self, grid: torch.Tensor) -> torch.Tensor:
        """``(N, in_channels, h, w)`` -> ``(N, out_channels, h, w)``."""
        h, w = grid.shape[-2:]
        m = 2 ** (len(self.down) - 1)
        x = F.pad(grid, (0, (-w) % m, 0, (-h) % m), mode="replicate")
        skips = []
        for i, block in enumerate(self.down):
            x = block(x if i == 0 else F.avg_pool2d(x, 2))
            skips.append(x)
        for i in reversed(range(len(self.up))):
            x = F.interpolate(x, size=skips[i].shape[-2:], mode="bilinear", align_corners=False)
            x = self.up[i](torch.cat([x, skips[i]], 1))
        return self.head(x)[..., :h, :w]


class ContextBlendNet(nn.Module):
    """Per-pixel blend of candidate fills that also reads scene context.

    Parameters
    ----------
    n_candidates : int
        Candidate fills ``K``.
    n_context : int
        Context features per pixel.
    widths : sequence of int
        :class:`ContextUNet` channels per level.
    width, layers : int
        Hidden units and layers of the per-pixel MLP.
    residual : bool
        Add the MLP's scale-free residual to the blend.

    Notes
    -----
    The per-pixel part is a relative :class:`PixelBlendNet` with 4 gap and 4 endpoint
    channels; its extra inputs are the context features and the pixel's candidate
    log-depth relative to the frame reference.
    """

    def __init__(self, n_candidates: int, n_context: int = 8, widths: Sequence[int] = (16, 32, 48, 64),
                 width: int = 64, layers: int = 2, residual: bool = True):
        super().__init__()
        self.n_context = n_context
        self.context = ContextUNet(len(GRID_BASE_CHANNELS) + n_candidates, n_context, widths)
        self.pixel = PixelBlendNet(n_candidates, 4, width, layers, n_endpoints=4, relative=True,
                                   residual=residual, n_extra=n_context + 1)

    @property
    def n_candidates(self) -> int:
        return self.pixel.n_candidates

    def mirror_order(self) -> list[int]:
        """Pixel-feature order of the mirrored frame (see :meth:`PixelBlendNet.mirror_order`)."""
        return self.pixel.mirror_order()

    @staticmethod
    def sample(features: torch.Tensor, rows: torch.Tensor, cols: torch.Tensor) -> torch.Tensor:
        """Bilinear context features ``(C, P)`` at full-resolution pixels of one frame.

        ``features`` is ``(C, h, w)`` with one cell per :data:`CELL` pixels; the last
        cells may overhang the frame. Beyond the outer cell centres the edge value holds.
        """
        _, hh, ww = features.shape
        gy = (rows.float() + 0.5) / (hh * CELL) * 2 - 1
        gx = (cols.float() + 0.5) / (ww * CELL) * 2 - 1
        grid = torch.stack([gx, gy], 1)[None, None]
        return F.grid_sample(features[None], grid, mode="bilinear", padding_mode="border",
                             align_corners=False)[0, :, 0]

    def blend_pixels(self, channels: torch.Tensor, context: torch.Tensor, ref: torch.Tensor | float) -> torch.Tensor:
        """Depth ``(P,)`` from channel-major pixel features ``(K + 8, P)`` and context ``(n_context, P)``.

        ``ref`` is the frame's reference log-depth (a number, or ``(P,)`` for pixels of
        several frames).
        """
        k = self.n_candidates
        rel = torch.log(channels[:k].clamp_min(MIN_DEPTH)).mean(dim=0, keepdim=True) - ref
        return self.pixel.blend_channels(channels, torch.cat([context, rel], dim=0))


class ContextBlendEnsemble(nn.Module):
    """Several :class:`ContextBlendNet` of one architecture, trained from different seeds.

    The estimator averages their predictions (:class:`~estimators.learned.ContextBlendInpainter`
    with ``n_members > 1``). Averaging cannot make a frame's error worse than the
    members' mean error: the squared error is convex in the prediction.

    Parameters
    ----------
    members : sequence of ContextBlendNet
    """

    def __init__(self, members: Sequence[ContextBlendNet]):
        super().__init__()
        if len(members) < 2:
            raise InvalidInputError(f"an ensemble needs at least 2 members, got {len(members)}")
        self.members = nn.ModuleList(members)

    @property
    def n_candidates(self) -> int:
        return self.members[0].n_candidates

    def mirror_order(self) -> list[int]:
        """Pixel-feature order of the mirrored frame (the same for every member)."""
        return self.members[0].mirror_order()
