"""A per-pixel MLP that blends classical candidate fills using the gaps they bridge.

For every pixel to fill, the inputs are the K candidate fills (metres / 80) and the
log-lengths of the gaps to the nearest measurement left, right, above and below; an MLP
(``layers`` hidden layers of ``width`` units, ReLU) outputs K blend logits and a
residual::

    depth = Σ_k softmax(logits)_k · candidate_k + 80 m · residual

The last layer starts at zero, so an untrained model is the mean of the candidates.
With ``relative=True`` depths enter as log-ratios to the candidates' geometric mean
and the residual is a fraction of it, which makes the model exactly scale-equivariant.
It has no notion of absolute image position on purpose: in probes on KITTI, position
features let a model memorise the training drive's layout (see docs/model_card.md).
Only pixels asked for are computed, so training on hole pixels and predicting on
unknown pixels costs time in proportion to those pixels alone.

Sizes are taken as given (positive integers): the estimators check their parameters
(:mod:`estimators._constraints`) and the size limits before they build a network.
"""

from __future__ import annotations

import contextlib
import itertools
from typing import Any

import torch
from torch import nn

__all__ = ["PixelBlendNet", "fill_holes"]

DEPTH_SCALE = 80.0
#: log1p(pixels) / GAP_SCALE keeps the gap inputs near [0, 1] (log1p(2048) ≈ 7.6).
GAP_SCALE = 7.0
#: Floor (metres) before logarithms in ``relative`` mode (candidates are 0 only on empty frames).
MIN_DEPTH = 1e-3
#: Pixels per chunk when a whole frame is predicted. Small enough that a chunk's
#: activations (8192 x 128 floats = 4 MB) stay in cache: 1.5x faster on the 2-core CPU
#: than 1 << 18 (``python perf/bench_pretrained.py --chunk 8192 --chunk 262144``).
CHUNK = 1 << 13


class PixelBlendNet(nn.Module):
    """Per-pixel blend of candidates plus residual, from candidates and gap lengths.

    Parameters
    ----------
    n_candidates : int
        Candidate channels ``K`` (after depth, hole and valid).
    n_gaps : int
        Gap-length channels after the candidates (4: left, right, up, down).
    n_endpoints : int, default 0
        Endpoint-depth channels after the gap lengths (4: the depth of the nearest
        measurement left, right, above, below; metres).
    width : int
        Hidden units per layer.
    layers : int
        Hidden layers.
    relative : bool, default False
        Scale-free inputs and output: candidates and endpoint depths enter as
        ``log(value / ref)`` with ``ref`` the geometric mean of the pixel's candidates,
        and the residual is a fraction of ``ref``. Multiplying all depths by ``s`` then
        multiplies the prediction by ``s`` (the model cannot key on a drive's depth range).
    residual : bool, default True
        Add the learned residual to the blend; without it the prediction is a convex
        combination of the candidates (the head keeps its residual output, unused).

    Notes
    -----
    Input ``(N, 3 + K + n_gaps + n_endpoints, H, W)`` as built by
    :func:`estimators.candidates.prior_features` with ``gaps=True`` (and ``endpoints=True``).
    """

    def __init__(
        self, n_candidates: int = 4, n_gaps: int = 4, width: int = 128, layers: int = 3, n_endpoints: int = 0,
        relative: bool = False,
        residual: bool = True,
        n_extra: int = 0,
    ):
        super().__init__()
        self.n_candidates, self.n_gaps, self.width, self.layers = n_candidates, n_gaps, width, layers
        self.n_endpoints = n_endpoints
        self.relative = bool(relative)
        self.residual = bool(residual)
        self.n_extra = n_extra
        dims = [n_candidates + n_gaps + n_endpoints + n_extra] + [width] * layers
        mods: list[nn.Module] = []
        for a, b in itertools.pairwise(dims):
            mods += [nn.Linear(a, b), nn.ReLU(inplace=True)]
        self.body = nn.Sequential(*mods)
        self.head = nn.Linear(width, n_candidates + 1)
        nn.init.zeros_(self.head.weight)
        nn.init.zeros_(self.head.bias)

    @property
    def in_channels(self) -> int:
        """Expected input channels ``3 + K + n_gaps + n_endpoints``."""
        return 3 + self.n_candidates + self.n_gaps + self.n_endpoints

    def mirror_order(self) -> list[int]:
        """Pixel-feature channel order of the mirrored frame: left and right swapped.

        Every candidate fill is mirror-symmetric, so a mirrored pixel's features are its
        own with the left/right gap (and endpoint) channels exchanged.
        """
        k = self.n_candidates
        order = list(range(k + self.n_gaps + self.n_endpoints))
        order[k], order[k + 1] = k + 1, k
        if self.n_endpoints:
            e = k + self.n_gaps
            order[e], order[e + 1] = e + 1, e
        return order

    def blend(self, pixels: torch.Tensor) -> torch.Tensor:
        """``(P, K + n_gaps + n_endpoints)`` raw pixel features (metres, pixels) -> ``(P,)`` metres."""
        return self.blend_channels(pixels.T)

    def blend_channels(self, channels: torch.Tensor, extra: torch.Tensor | None = None) -> torch.Tensor:
        """:meth:`blend` of channel-major features ``(K + n_gaps + n_endpoints, P)``.

        ``extra`` (``(n_extra, P)``, required when ``n_extra > 0``) enters the MLP as
        given, after the transformed pixel features: e.g. scene context from
        :class:`~estimators.learned.nets.context_blend.ContextBlendNet`.

        The per-candidate work (logarithms, the geometric mean, the softmax) runs on
        contiguous rows of P pixels: on a pixel-major ``(P, K)`` slice the same
        operations stride through memory and cost ~10x more on the CPU.
        """
        k, g = self.n_candidates, self.n_candidates + self.n_gaps
        channels = channels.contiguous()
        cands = channels[:k]
        gaps = torch.log1p(channels[k:g]) / GAP_SCALE
        if self.relative:
            # log-ratios to the candidates' geometric mean: exact scale equivariance.
            log_c = torch.log(cands.clamp_min(MIN_DEPTH))
            log_ref = log_c.mean(dim=0, keepdim=True)
            ends = channels[g:]
            # A missing endpoint (0 m) enters as 0, like "equal to ref"; its gap length tells.
            log_e = torch.where(ends > 0, torch.log(ends.clamp_min(MIN_DEPTH)) - log_ref, 0.0)
            z = torch.cat([log_c - log_ref, gaps, log_e], dim=0)
            scale = torch.exp(log_ref[0])
        else:
            z = torch.cat([cands / DEPTH_SCALE, gaps, channels[g:] / DEPTH_SCALE], dim=0)
            scale = DEPTH_SCALE
        if self.n_extra:
            if extra is None or extra.shape != (self.n_extra, channels.shape[1]):
                got = None if extra is None else tuple(extra.shape)
                raise ValueError(f"expected extra inputs ({self.n_extra}, {channels.shape[1]}), got {got}")
            z = torch.cat([z, extra], dim=0)
        out = self.head(self.body(z.T)).T
        blend = (torch.softmax(out[:k], dim=0) * cands).sum(dim=0)
        # Without the residual the output stays within the candidates' range.
        return blend + scale * out[k] if self.residual else blend

    def forward(self, x: torch.Tensor, where: torch.Tensor | None = None) -> torch.Tensor:
        """Predict at the pixels ``where`` (``(P,)`` metres) or on the whole map.

        Parameters
        ----------
        x : torch.Tensor
            ``(N, 3 + K + n_gaps, H, W)`` features.
        where : torch.Tensor, optional
            ``(N, H, W)`` bool. Without it, a full ``(N, H, W)`` map is returned: the
            blend on unmeasured pixels, the input depth on measured ones.
        """
        if x.ndim != 4 or x.shape[1] != self.in_channels:
            raise ValueError(f"expected input (N, {self.in_channels}, H, W), got {tuple(x.shape)}")
        channels_last = x[:, 3:].permute(0, 2, 3, 1)
        if where is not None:
            return self.blend(channels_last[where])
        unknown = x[:, 2] < 0.5
        out = x[:, 0].clone()
        pixels = channels_last[unknown]
        values = torch.cat([self.blend(p) for p in pixels.split(CHUNK)]) if len(pixels) else pixels[:, 0]
        out[unknown] = values.to(out.dtype)
        return out

    def extra_repr(self) -> str:
        return (f"n_candidates={self.n_candidates}, n_gaps={self.n_gaps}, n_endpoints={self.n_endpoints}, "
                f"width={self.width}, layers={self.layers}, relative={self.relative}, residual={self.residual}, "
                f"n_extra={self.n_extra}")


def fill_holes(
    model: PixelBlendNet, x: torch.Tensor, *, flip_average: bool = True, device: torch.device | None = None,
    autocast: Any = None,
) -> torch.Tensor:
    """Depth maps from ``(N, 3 + C, H, W)`` features, the network run on the hole pixels only.

    The network's cost grows with the pixels it runs on, and only the pixels to fill are
    asked for: measured pixels keep their depth, other unmeasured ones (LiDAR gaps
    outside the hole) take the candidates' mean, which is what the blend starts from
    before training.

    Parameters
    ----------
    model : PixelBlendNet
    x : torch.Tensor
        Features as built by :func:`estimators.candidates.prior_features` (depth, hole,
        valid, candidates, gap lengths, endpoints), on the CPU.
    flip_average : bool
        Average with the mirrored frame's prediction (:meth:`PixelBlendNet.mirror_order`).
    device : torch.device, optional
        Where the network runs (default: the CPU).
    autocast : context manager, optional
        Mixed-precision context for the network.

    Returns
    -------
    torch.Tensor
        ``(N, H, W)`` metres on the CPU. Hole pixels are floored at half the smallest
        candidate: a residual pushing a far pixel towards 0 m barely moves RMSE but
        explodes inverse-depth errors.
    """
    k = model.n_candidates
    feats = x[:, 3:]
    pred = torch.where(x[:, 2] > 0.5, x[:, 0], feats[:, :k].mean(dim=1))
    hole = x[:, 1] > 0.5
    # Channel-major (C, P): the per-candidate work runs on contiguous rows.
    channels = feats.permute(1, 0, 2, 3)[:, hole]
    if not channels.shape[1]:
        return pred
    mirrored = model.mirror_order() if flip_average else None
    values = []
    with autocast if autocast is not None else contextlib.nullcontext():
        for c in channels.split(CHUNK, dim=1):
            c = c.contiguous() if device is None else c.to(device).contiguous()
            v = model.blend_channels(c).float()
            if mirrored is not None:
                v = 0.5 * (v + model.blend_channels(c[mirrored]).float())
            values.append(v.cpu())
    pred[hole] = torch.maximum(torch.cat(values), 0.5 * channels[:k].min(dim=0).values)
    return pred
