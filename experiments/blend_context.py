"""A low-resolution context CNN on top of the learned blend, leave-one-drive-out (issue 15).

The blend (``kitti-rect-v4``) sees one pixel's candidate fills. This probe asks whether a
small CNN that sees the whole frame at 1/4 resolution can add what the candidates miss:
it reads the measured log-depth, its density, the hole fraction and the blend's
log-depth per 4×4 cell (each relative to the frame's median measured log-depth, so it is
scale-free), and outputs a log-depth correction per cell, upsampled bilinearly and
applied as ``blend · exp(correction)`` in the hole. A U-Net of 3×3 conv + GroupNorm +
ReLU blocks (16/32/64 channels, ~120 k parameters), last layer zero-initialised (an
untrained CNN returns the blend); the loss is the squared error in metres per cell,
weighted by the cell's ground-truth pixels in the hole.

``cache``
    For each train drive D, with the blend trained without D by ``experiments/lodo.sh``
    (``RUNS/train-D/model``): low-resolution inputs and targets of the other train
    drives' frames (occlusion seeds 1000, 1001 and 1002 thinned to 65 %) and, for D's
    and the val frames, the evaluation occlusions (seeds 0 and 1) with the blend's and
    the classical fills' values on every hole pixel with ground truth.
``fit``
    Train the CNN per fold and print, per scored drive, the blend's and blend+CNN's mean
    per-frame hole RMSE ÷ the strongest classical method, with the paired 95 % interval.

Examples
--------
    bash experiments/lodo.sh <KITTI root> lodo-runs
    python experiments/blend_context.py cache --kitti-root <KITTI root> --runs lodo-runs --out context-cache
    python experiments/blend_context.py fit --cache context-cache --epochs 12
"""

from __future__ import annotations

import argparse
import functools
import sys
import time
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F
from joblib import Parallel, delayed
from torch import nn

sys.path.insert(0, str(Path(__file__).resolve().parent))
from blend_lodo import corrupted_input, frames_by_drive, versus_strongest

from estimators.blend import BlendInpainter
from estimators.priors import candidate_fills
from inpaintenv.masks import get_protocol

FACTOR = 4
CLASSICAL = ("scanline", "scanline-inverse", "harmonic", "harmonic-inverse")
#: (occlusion seed, fraction of measured pixels kept) of the training inputs.
TRAIN_MASKS = ((1000, 1.0), (1001, 1.0), (1002, 0.65))


def pool_sum(a: np.ndarray) -> np.ndarray:
    """Sum over FACTOR x FACTOR cells of an ``(H, W)`` array whose sides are multiples of FACTOR."""
    h, w = a.shape
    return a.reshape(h // FACTOR, FACTOR, w // FACTOR, FACTOR).sum(axis=(1, 3))


def lowres_inputs(x: np.ndarray, blend: np.ndarray, gt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(4, H/4, W/4)`` CNN inputs and ``(3, H/4, W/4)`` targets (pixels, mean gt, mean blend) of one frame.

    The frame is cropped to multiples of :data:`FACTOR`.
    """
    h, w = (s // FACTOR * FACTOR for s in x.shape)
    x, blend, gt = x[:h, :w], blend[:h, :w], gt[:h, :w]
    hole = np.isnan(x)
    measured = np.nan_to_num(x) > 0
    log_d = np.log(np.where(measured, x, 1.0))
    ref = float(np.median(log_d[measured])) if measured.any() else 0.0
    count = pool_sum(measured.astype(np.float32))
    mean_log_d = np.where(count > 0, pool_sum(np.where(measured, log_d, 0.0)) / np.maximum(count, 1) - ref, 0.0)
    log_blend = pool_sum(np.log(np.maximum(blend, 1e-3))) / FACTOR**2 - ref
    inputs = np.stack([mean_log_d, count / FACTOR**2, pool_sum(hole.astype(np.float32)) / FACTOR**2, log_blend])
    scored = hole & (gt > 0)
    n = pool_sum(scored.astype(np.float32))
    mean_of = lambda a: np.where(n > 0, pool_sum(np.where(scored, a, 0.0)) / np.maximum(n, 1), 0.0)
    return inputs.astype(np.float32), np.stack([n, mean_of(gt), mean_of(blend)]).astype(np.float32)


@functools.lru_cache(maxsize=1)
def _fold_blend(model_dir: Path) -> BlendInpainter:
    """The fold's blend, read once per worker process (each job would otherwise read and verify it again)."""
    return BlendInpainter.load(model_dir)


def _sample(model_dir: Path, gt: np.ndarray, hole: np.ndarray, seed: int, keep: float, evaluation: bool) -> dict:
    torch.set_num_threads(1)
    est = _fold_blend(model_dir)
    x = corrupted_input(gt, hole, keep, np.random.default_rng(seed))
    blend = est.predict(x)
    inputs, targets = lowres_inputs(x, blend, gt)
    out = {"inputs": inputs, "targets": targets}
    if evaluation:
        rows, cols = np.nonzero(hole & (gt > 0))
        out.update(rows=rows, cols=cols, y=gt[rows, cols], blend=blend[rows, cols],
                   classical={c: f[rows, cols] for c, f in zip(CLASSICAL, candidate_fills(x, CLASSICAL))})
    return out


def cmd_cache(args: argparse.Namespace) -> None:
    protocol = get_protocol("rect-v1")
    frames = frames_by_drive(args.kitti_root)
    held_out = sorted(d for s, d in frames if s == "train")
    for held in held_out:
        path = Path(args.out) / f"{held}.pt"
        model_dir = Path(args.runs) / f"train-{held}" / "model"
        if path.exists():
            continue
        if not (model_dir / "config.json").exists():
            raise SystemExit(f"no blend trained without {held} in {model_dir}: run experiments/lodo.sh first")
        jobs, meta = [], []
        for (split, drive), batch in frames.items():
            for i, gt in enumerate(batch):
                if not (gt > 0).any():
                    continue
                if split == "train" and drive != held:
                    for seed, keep in TRAIN_MASKS:
                        jobs.append(delayed(_sample)(model_dir, gt, protocol.mask(gt.shape, seed, i), seed * 7 + i,
                                                     keep, False))
                        meta.append({"kind": "train", "drive": drive})
                else:
                    for seed in args.seeds:
                        jobs.append(delayed(_sample)(model_dir, gt, protocol.mask(gt.shape, seed, i), seed, 1.0, True))
                        meta.append({"kind": "eval", "drive": drive})
        start = time.perf_counter()
        results = Parallel(n_jobs=args.jobs)(jobs)
        print(f"fold {held}: {len(jobs)} (frame, occlusion) in {time.perf_counter() - start:.0f} s", flush=True)
        path.parent.mkdir(parents=True, exist_ok=True)
        torch.save({"results": results, "meta": meta}, path)


def _block(c_in: int, c_out: int) -> nn.Sequential:
    return nn.Sequential(nn.Conv2d(c_in, c_out, 3, padding=1), nn.GroupNorm(4, c_out), nn.ReLU(inplace=True),
                         nn.Conv2d(c_out, c_out, 3, padding=1), nn.GroupNorm(4, c_out), nn.ReLU(inplace=True))


class ContextNet(nn.Module):
    """Three-level U-Net from 4 low-resolution channels to one log-depth correction."""

    def __init__(self, width: int = 16):
        super().__init__()
        self.enc1, self.enc2, self.enc3 = _block(4, width), _block(width, 2 * width), _block(2 * width, 4 * width)
        self.dec2, self.dec1 = _block(6 * width, 2 * width), _block(3 * width, width)
        self.out = nn.Conv2d(width, 1, 1)
        nn.init.zeros_(self.out.weight)
        nn.init.zeros_(self.out.bias)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        a = self.enc1(x)
        b = self.enc2(F.avg_pool2d(a, 2))
        c = self.enc3(F.avg_pool2d(b, 2))
        up = lambda t, like: F.interpolate(t, size=like.shape[-2:], mode="bilinear", align_corners=False)
        d = self.dec2(torch.cat([up(c, b), b], 1))
        return self.out(self.dec1(torch.cat([up(d, a), a], 1)))


def train_context(inputs: torch.Tensor, targets: torch.Tensor, epochs: int, seed: int, batch: int = 8,
                  lr: float = 1e-3) -> ContextNet:
    torch.manual_seed(seed)
    net = ContextNet()
    optimizer = torch.optim.Adam(net.parameters(), lr=lr, weight_decay=1e-6)
    rng = np.random.default_rng(seed)
    for _ in range(epochs):
        order = rng.permutation(len(inputs))
        for start in range(0, len(order) - batch + 1, batch):
            idx = torch.from_numpy(order[start:start + batch])
            xb, tb = inputs[idx], targets[idx]
            if rng.random() < 0.5:
                xb, tb = xb.flip(-1), tb.flip(-1)
            n, gt, blend = tb[:, 0], tb[:, 1], tb[:, 2]
            loss = (n * (blend * torch.exp(net(xb)[:, 0]) - gt) ** 2).sum() / n.sum().clamp_min(1)
            optimizer.zero_grad(set_to_none=True)
            loss.backward()
            optimizer.step()
    return net.eval()


def cmd_fit(args: argparse.Namespace) -> dict:
    torch.set_num_threads(args.threads)
    report = {}
    for path in sorted(Path(args.cache).glob("*.pt")):
        held = path.stem
        data = torch.load(path, weights_only=False)
        results, meta = data["results"], data["meta"]
        train = [r for r, m in zip(results, meta) if m["kind"] == "train"]
        start = time.perf_counter()
        net = train_context(torch.from_numpy(np.stack([r["inputs"] for r in train])),
                            torch.from_numpy(np.stack([r["targets"] for r in train])), args.epochs, args.seed)
        fit_s = time.perf_counter() - start
        rmse: dict[str, list[float]] = {"blend": [], "blend+context": [], **{c: [] for c in CLASSICAL}}
        drives = []
        with torch.inference_mode():
            for r, m in zip(results, meta):
                if m["kind"] != "eval" or not len(r["y"]):
                    continue
                x = torch.from_numpy(r["inputs"][None])
                corr = 0.5 * (net(x) + net(x.flip(-1)).flip(-1))  # flip average, as the blend does
                full = F.interpolate(corr, scale_factor=FACTOR, mode="bilinear", align_corners=False)[0, 0].numpy()
                rows = np.minimum(r["rows"], full.shape[0] - 1)
                cols = np.minimum(r["cols"], full.shape[1] - 1)
                preds = {"blend": r["blend"], "blend+context": r["blend"] * np.exp(full[rows, cols]),
                         **r["classical"]}
                for name, pred in preds.items():
                    rmse[name].append(float(np.sqrt(np.mean((pred - r["y"]) ** 2))))
                drives.append(m["drive"])
        arrays = {k: np.array(v) for k, v in rmse.items()}
        drives_arr = np.array(drives)
        classical = {c: arrays[c] for c in CLASSICAL}
        report[held] = {}
        for drive in sorted(set(drives)):
            sel = drives_arr == drive
            for name in ("blend", "blend+context"):
                best, ratio, lo, hi = versus_strongest(arrays[name], classical, sel)
                report[held][f"{drive} {name}"] = {"frames": int(sel.sum()), "ratio": ratio, "ci": [lo, hi]}
                print(f"without {held:28s} scored {drive:28s} n={sel.sum():3d} {name:14s} "
                      f"{arrays[name][sel].mean():6.3f} m  {best:16s} {arrays[best][sel].mean():6.3f} m  "
                      f"ratio {ratio:.3f} [{lo:.3f}, {hi:.3f}]  (fit {fit_s:.0f} s)", flush=True)
    return report


def main(argv: list[str] | None = None) -> dict | None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("cache", help="low-resolution inputs of every fold, with the fold's blend")
    c.add_argument("--kitti-root", required=True)
    c.add_argument("--runs", required=True, help="the OUT folder of experiments/lodo.sh (train-<drive>/model)")
    c.add_argument("--out", required=True)
    c.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    c.add_argument("--jobs", type=int, default=2)
    f = sub.add_parser("fit", help="train the context CNN per fold and score it")
    f.add_argument("--cache", required=True)
    f.add_argument("--epochs", type=int, default=12)
    f.add_argument("--seed", type=int, default=0)
    f.add_argument("--threads", type=int, default=2)
    args = p.parse_args(argv)
    return {"cache": cmd_cache, "fit": cmd_fit}[args.cmd](args)


if __name__ == "__main__":
    main()
