"""Probe: a normalized-convolution network (confidence propagation), leave-one-drive-out.

Issue 15 names normalized convolutions with confidence propagation among the cheap ways
to see more context than one pixel's candidates. This script measures that direction the
way every recipe here is chosen: trained on two ``train`` drives, scored on the third
(seeds 0-1, rect-v1, the benchmark's masks for ``--drives <drive>``), the official frame of
``val`` scored with each fold's model as a check only.

The network follows the unguided design of normalized-convolution depth completion: every
layer is a normalized convolution (non-negative weights through softplus; output = the
weighted mean of the inputs where they are confident, plus a bias; output confidence = the
weights' coverage of confident inputs). Downsampling keeps the most confident pixel of each
2×2 block, so holes fill from coarse scales, and upsampling merges every scale back to full
resolution. Inputs are scale-free (depth ÷ the frame's median measured depth, confidence 1 on
measured pixels, 0 in holes and LiDAR gaps); the loss is the squared error on hole pixels
with ground truth, the quantity the benchmark scores.

Results and what they mean: ``docs/reference/blend_limits.md``.

Examples
--------
    python experiments/nconv_probe.py --kitti-root <KITTI root> --steps 400
    python experiments/nconv_probe.py --kitti-root <KITTI root> --steps 0 --folds 2011_09_26_drive_9002_sync
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

sys.path.insert(0, str(Path(__file__).resolve().parent))
from blend_lodo import corrupted_input, frames_by_drive, versus_strongest

from estimators.priors import candidate_fills
from inpaintenv.masks import get_protocol
from inpaintenv.metrics import ScoredPixels

#: Classical fills scored beside the network (the strongest per drive is the reference).
CLASSICAL = ("harmonic", "harmonic-inverse", "scanline", "scanline-inverse")
#: Training masks use seeds from here on, never the evaluation seeds.
TRAIN_SEED0 = 1000
KEEP = (1.0, 0.65, 0.4)
EPS = 1e-6


class NConv2d(nn.Module):
    """Normalized convolution: confidence-weighted mean with non-negative weights, plus a bias."""

    def __init__(self, cin: int, cout: int, kernel: int):
        super().__init__()
        self.weight = nn.Parameter(torch.rand(cout, cin, kernel, kernel) * 0.5 + 0.5)
        self.bias = nn.Parameter(torch.zeros(cout))
        self.pad = kernel // 2

    def forward(self, x: torch.Tensor, c: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        w = F.softplus(self.weight)
        den = F.conv2d(c, w, padding=self.pad)
        num = F.conv2d(x * c, w, padding=self.pad)
        out = num / (den + EPS) + self.bias.view(1, -1, 1, 1)
        conf = den / w.sum(dim=(1, 2, 3)).view(1, -1, 1, 1)
        return out, conf


def _down(x: torch.Tensor, c: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Keep each 2×2 block's most confident pixel (its value and confidence)."""
    c_down, idx = F.max_pool2d(c, 2, 2, ceil_mode=True, return_indices=True)
    x_down = x.flatten(2).gather(2, idx.flatten(2)).view_as(c_down)
    return x_down, c_down


class NConvNet(nn.Module):
    """Multi-scale normalized-convolution network; the scale layers share weights (scale-invariant).

    Parameters
    ----------
    channels : int
        Channels of every layer.
    scales : int
        Number of 2× downsamplings (5: a 1/32 scale, reach of a few hundred pixels).
    upsample : {"nearest", "bilinear"}
        How coarse scales return to the finer ones (values and confidences alike).
    """

    def __init__(self, channels: int = 4, scales: int = 5, upsample: str = "nearest"):
        super().__init__()
        if upsample not in ("nearest", "bilinear"):
            raise ValueError(f"upsample must be 'nearest' or 'bilinear', got {upsample!r}")
        self.scales = scales
        self.upsample = upsample
        self.first = nn.ModuleList([NConv2d(1, channels, 5), NConv2d(channels, channels, 5)])
        self.level = nn.ModuleList([NConv2d(channels, channels, 5), NConv2d(channels, channels, 5)])
        self.merge = NConv2d(2 * channels, channels, 3)
        self.last = NConv2d(channels, 1, 1)

    def forward(self, x: torch.Tensor, c: torch.Tensor) -> torch.Tensor:
        for layer in self.first:
            x, c = layer(x, c)
        pyramid = [(x, c)]
        for _ in range(self.scales):
            x, c = _down(x, c)
            for layer in self.level:
                x, c = layer(x, c)
            pyramid.append((x, c))
        x, c = pyramid.pop()
        while pyramid:
            x_skip, c_skip = pyramid.pop()
            size = x_skip.shape[-2:]
            # Interpolate x·c and c, then divide: unconfident coarse pixels do not leak in.
            kw = {"size": size, "mode": self.upsample}
            if self.upsample == "bilinear":
                kw["align_corners"] = False
            c_up = F.interpolate(c, **kw)
            x_up = F.interpolate(x * c, **kw) / (c_up + EPS)
            x, c = self.merge(torch.cat([x_skip, x_up], 1), torch.cat([c_skip, c_up], 1))
        x, _ = self.last(x, c)
        return x


def _inputs(x: np.ndarray) -> tuple[torch.Tensor, torch.Tensor, float]:
    """Scale-free network input of one corrupted frame (NaN = hole, 0 = no measurement)."""
    known = np.nan_to_num(x) > 0
    scale = float(np.median(x[known])) if known.any() else 1.0
    depth = np.where(known, np.nan_to_num(x) / scale, 0.0).astype(np.float32)
    return torch.from_numpy(depth)[None], torch.from_numpy(known.astype(np.float32))[None], scale


def predict(net: NConvNet, x: np.ndarray) -> np.ndarray:
    """Depth (metres) of one frame; measured pixels kept."""
    d, c, scale = _inputs(x)
    with torch.inference_mode():
        out = net(d[None], c[None])[0, 0].numpy() * scale
    known = np.nan_to_num(x) > 0
    # The bias can push a fill below zero; 0.5 m is a floor nearer than any KITTI depth (>= 2 m here).
    return np.where(known, x, np.maximum(out, 0.5)).astype(np.float32)


def train(frames: list[np.ndarray], steps: int, batch: int, seed: int, lr: float = 1e-2,
          channels: int = 4, scales: int = 5, crop_width: int = 608, upsample: str = "nearest") -> NConvNet:
    """Fit on random rect-v1 occlusions (training seeds) of ``frames``, inputs thinned to 100/65/40 %.

    Each sample is a random ``crop_width``-column window of the occluded frame (full height),
    which halves the step time at the default width.
    """
    torch.manual_seed(seed)
    rng = np.random.default_rng([seed, 0xC0FF])
    protocol = get_protocol("rect-v1")
    net = NConvNet(channels, scales, upsample)
    optimizer = torch.optim.Adam(net.parameters(), lr=lr)
    # steps=0 scores the untrained net: a fixed multi-scale confidence-weighted average.
    schedule = torch.optim.lr_scheduler.OneCycleLR(optimizer, max_lr=lr, total_steps=max(steps, 1), pct_start=0.1)
    for step in range(steps):
        ds, cs, ys, ws = [], [], [], []
        for _ in range(batch):
            i = int(rng.integers(len(frames)))
            gt = frames[i]
            hole = protocol.mask(gt.shape, TRAIN_SEED0 + int(rng.integers(1 << 20)), i)
            if rng.random() < 0.5:  # mirror augmentation
                gt, hole = gt[:, ::-1].copy(), hole[:, ::-1].copy()
            if crop_width < gt.shape[1]:
                left = int(rng.integers(gt.shape[1] - crop_width + 1))
                gt, hole = gt[:, left:left + crop_width], hole[:, left:left + crop_width]
            x = corrupted_input(gt, hole, float(rng.choice(KEEP)), rng)
            d, c, scale = _inputs(x)
            target = hole & (gt > 0)
            ds.append(d)
            cs.append(c)
            ys.append(torch.from_numpy(np.where(target, gt / scale, 0.0).astype(np.float32))[None])
            # Each frame weighs the same whatever its hole size (the benchmark averages per frame).
            ws.append(torch.from_numpy(target.astype(np.float32) * scale ** 2 / max(target.sum(), 1))[None])
        pred = net(torch.stack(ds), torch.stack(cs))
        w = torch.stack(ws)
        loss = (w * (pred - torch.stack(ys)).square()).sum() / batch
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        optimizer.step()
        schedule.step()
        if step % 100 == 0 or step == steps - 1:
            print(f"  step {step:4d} loss {loss.item():.2f} (m², per-frame hole MSE)", flush=True)
    return net.eval()


def score(net: NConvNet, frames: list[np.ndarray], seeds: list[int]) -> dict[str, np.ndarray]:
    """Per (frame, seed) hole RMSE of the network and of each :data:`CLASSICAL` fill."""
    protocol = get_protocol("rect-v1")
    out: dict[str, list[float]] = {"nconv": [], **{c: [] for c in CLASSICAL}}
    for i, gt in enumerate(frames):
        for s in seeds:
            hole = protocol.mask(gt.shape, s, i)
            scored = ScoredPixels(gt, hole)  # the benchmark's scorer: ground truth gathered once
            if not scored.hole_count:
                continue
            x = np.where(hole, np.nan, gt).astype(np.float32)
            fills = dict(zip(CLASSICAL, candidate_fills(x, CLASSICAL)))
            fills["nconv"] = predict(net, x)
            for name, fill in fills.items():
                out[name].append(float(scored.metrics(fill)["hole_rmse"]))
    return {k: np.array(v) for k, v in out.items()}


def main(argv: list[str] | None = None) -> dict:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--kitti-root", required=True)
    p.add_argument("--steps", type=int, default=400, help="training steps per fold (0: untrained)")
    p.add_argument("--batch", type=int, default=4)
    p.add_argument("--channels", type=int, default=4)
    p.add_argument("--scales", type=int, default=5)
    p.add_argument("--upsample", choices=["nearest", "bilinear"], default="nearest")
    p.add_argument("--lr", type=float, default=1e-2)
    p.add_argument("--crop-width", type=int, default=608, help="columns of each training crop")
    p.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    p.add_argument("--seed", type=int, default=0, help="training seed")
    p.add_argument("--folds", nargs="*", help="held-out drives (default: every train drive)")
    p.add_argument("--json", help="write the results here")
    args = p.parse_args(argv)
    torch.set_num_threads(2)
    frames = frames_by_drive(args.kitti_root)
    train_drives = sorted(d for (s, d) in frames if s == "train")
    results = {}
    for held in args.folds or train_drives:
        pool = [gt for (s, d), fs in frames.items() if s == "train" and d != held for gt in fs if (gt > 0).any()]
        start = time.perf_counter()
        net = train(pool, args.steps, args.batch, args.seed, lr=args.lr, channels=args.channels, scales=args.scales,
                    crop_width=args.crop_width, upsample=args.upsample)
        fit_s = time.perf_counter() - start
        x = np.where(get_protocol("rect-v1").mask(pool[0].shape, 0, 0), np.nan, pool[0]).astype(np.float32)
        predict(net, x)
        start = time.perf_counter()
        predict(net, x)
        ms = 1000 * (time.perf_counter() - start)
        for (split, drive), fs in frames.items():
            if drive != held and split == "train":
                continue
            rmse = score(net, fs, args.seeds)
            sel = np.ones(len(rmse["nconv"]), bool)
            classical = {c: rmse[c] for c in CLASSICAL}
            best, r, lo, hi = versus_strongest(rmse["nconv"], classical, sel)
            label = drive if split == "train" else f"{drive} (model without {held})"
            results[label] = {"frames": int(sel.sum()), "nconv_rmse": float(rmse["nconv"].mean()), "classical": best,
                              "classical_rmse": float(classical[best].mean()), "ratio": r, "ci": [lo, hi],
                              "fit_s": round(fit_s), "predict_ms": round(ms)}
            print(f"{label:58s} n={sel.sum():3d} nconv {rmse['nconv'].mean():6.3f} m  {best:16s} "
                  f"{classical[best].mean():6.3f} m  ratio {r:.3f} [{lo:.3f}, {hi:.3f}]  "
                  f"(fit {fit_s:.0f} s, predict {ms:.0f} ms)", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1))
    return results


if __name__ == "__main__":
    main()
