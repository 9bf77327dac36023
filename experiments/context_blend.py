"""Leave-one-day-out experiments for a context-aware learned blend on the real KITTI slice.

The per-pixel blend (``kitti-rect-v4``) sees only what lies on the four axis lines
through a pixel. This experiment adds a scene context: a small CNN that reads the whole
frame at a quarter of its resolution (observed log-depth, density, hole, the candidate
fills; all relative to the frame's median depth, so scale-free) and hands each pixel a
few context features, which the per-pixel MLP reads beside its own. Both are trained
together on cached samples.

``cache``
    For every frame with ground truth (``train`` drives, both cameras of drives that have
    them, and ``val``): ``--train-masks`` rect-v1 occlusions with training seeds
    (>= 1000, never the evaluation seeds), each as given and thinned (``--keep``), with
    ``--pixels`` hole pixels kept; and the evaluation occlusions (seeds ``--seeds``) with
    every hole pixel with ground truth. Per sample: the pixels' features (every candidate
    fill, gap lengths, endpoint depths), their coordinates and truth, and the
    quarter-resolution context.
``fit``
    For each variant and fold (a recording day, or a drive, left out): train on the other
    samples, predict the held-out evaluation samples and print the mean per-frame hole
    RMSE, that of the strongest classical fill on the same frame-masks, and the ratio
    with a paired 95 % bootstrap interval.
``select``
    Chooses between variants without looking at the frames ``fit`` reports: for each fold,
    a ``GroupKFold`` over the drives of that fold's *training* samples (``--inner``
    splits); each variant is trained on the other drives of every split and scored on the
    split's held-out drives; the variant with the lowest pooled ratio to the strongest
    classical fill is the fold's choice, and ``fit`` then reports that choice on the fold.

Examples
--------
    python experiments/context_blend.py cache --kitti-root <KITTI root> --out ctx-cache
    python experiments/context_blend.py fit --cache ctx-cache --variant blend --variant context
    python experiments/context_blend.py fit --cache ctx-cache --variant context-bal --preds ctx-preds   # one per
    python experiments/context_blend.py fit --cache ctx-cache --variant context-bal-s1 --preds ctx-preds  # process
    python experiments/context_blend.py fit --cache ctx-cache --variant context-bal --variant context-bal-s1 \
        --preds ctx-preds --ensemble                             # reads both back, scores their mean
    python experiments/context_blend.py select --cache ctx-cache --variant blend --variant context-bal \
        --folds "drive 0001"                                     # nested selection, then `fit` reports
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import torch
from joblib import Parallel, delayed
from torch import nn

from estimators.priors import AVAILABLE_CANDIDATES, prior_features
from inpaintenv.data import KittiDepth
from inpaintenv.masks import get_protocol

#: Per-pixel channels kept: every candidate, 4 gap lengths, 4 endpoint depths.
CHANNELS = [*AVAILABLE_CANDIDATES, "gap-l", "gap-r", "gap-u", "gap-d", "end-l", "end-r", "end-u", "end-d"]
#: Context channels: observed log-depth, density, hole fraction, then every candidate.
CONTEXT_CHANNELS = ["obs", "density", "hole", *AVAILABLE_CANDIDATES]
TRAIN_SEED0 = 1000
FACTOR = 4


def context_grid(x: np.ndarray, cands: np.ndarray, factor: int = FACTOR) -> tuple[np.ndarray, float]:
    """Quarter-resolution, scale-free context of one corrupted frame.

    Returns ``(C, ceil(H/f), ceil(W/f))`` float32 and the frame's reference log-depth
    (median log of the measured depth), which every log channel is relative to.
    """
    h, w = x.shape
    known = x > 0  # NaN > 0 is False
    ref = float(np.median(np.log(x[known]))) if known.any() else float(np.log(10.0))
    ph, pw = (-h) % factor, (-w) % factor

    def pool(a: np.ndarray) -> np.ndarray:
        a = np.pad(a, ((0, ph), (0, pw)))
        return a.reshape((h + ph) // factor, factor, (w + pw) // factor, factor).sum(axis=(1, 3))

    n = pool(known.astype(np.float32))
    logobs = pool(np.where(known, np.log(np.where(known, x, 1.0)) - ref, 0.0).astype(np.float32))
    obs = np.divide(logobs, n, out=np.zeros_like(logobs), where=n > 0)
    area = pool(np.ones((h, w), np.float32))
    hole = pool(np.isnan(x).astype(np.float32)) / area
    chans = [obs, n / area, hole]
    for c in cands:
        chans.append(pool((np.log(np.maximum(c, 1e-3)) - ref).astype(np.float32)) / area)
    return np.stack(chans).astype(np.float32), ref


def thinned_input(gt: np.ndarray, hole: np.ndarray, keep: float, rng: np.random.Generator) -> np.ndarray:
    """NaN in the hole; outside it, a fraction ``1 - keep`` of the measured pixels dropped."""
    x = np.where(hole, np.nan, gt).astype(np.float32)
    if keep < 1.0:
        x[(gt > 0) & ~hole & (rng.random(gt.shape) >= keep)] = 0.0
    return x


def one_sample(gt: np.ndarray, hole: np.ndarray, keep: float, n_pixels: int | None, seed: int) -> dict:
    rng = np.random.default_rng(seed)
    x = thinned_input(gt, hole, keep, rng)
    feats = prior_features(x, AVAILABLE_CANDIDATES, gaps=True, endpoints=True)[3:]
    ctx, ref = context_grid(x, feats[: len(AVAILABLE_CANDIDATES)])
    rows, cols = np.nonzero(hole & (gt > 0))
    if n_pixels is not None and len(rows) > n_pixels:
        pick = np.sort(rng.choice(len(rows), n_pixels, replace=False))
        rows, cols = rows[pick], cols[pick]
    return {"x": feats[:, rows, cols].T.astype(np.float32), "y": gt[rows, cols].astype(np.float32),
            "rc": np.stack([rows, cols], 1).astype(np.int16), "ctx": ctx.astype(np.float16), "ref": ref,
            "shape": gt.shape}


def frame_sets(kitti_root: str) -> list[tuple[dict, KittiDepth]]:
    """(meta, dataset) per (split, drive, camera) with ground truth in the layout."""
    sets = []
    for split in ("train", "val"):
        for camera in ("image_02", "image_03"):
            try:
                ds = KittiDepth(kitti_root, split=split, camera=camera)
            except (FileNotFoundError, ValueError):
                continue
            for drive in sorted({str(g) for g in ds.groups}):
                sub = KittiDepth(kitti_root, split=split, camera=camera, drives=[drive])
                sets.append(({"split": split, "drive": drive, "camera": camera, "day": drive[:10]}, sub))
    return sets


def cmd_cache(args: argparse.Namespace) -> None:
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    protocol = get_protocol("rect-v1")
    jobs, meta = [], []
    for info, ds in frame_sets(args.kitti_root):
        frames = ds.load_batch(range(min(len(ds), args.limit or len(ds))))
        for i, gt in enumerate(frames):
            if not (gt > 0).any():
                continue
            base = {**info, "frame": i, "frame_id": ds.frame_ids[i]}
            for s in args.seeds:  # the benchmark's masks for --drives <drive> --camera <camera>
                jobs.append(delayed(one_sample)(gt, protocol.mask(gt.shape, s, i), 1.0, None, s))
                meta.append({**base, "kind": "eval", "seed": s, "keep": 1.0})
            if info["split"] == "train" and i % args.train_every == 0:
                for m in range(args.train_masks):
                    s = TRAIN_SEED0 + m
                    hole = protocol.mask(gt.shape, s, i)
                    for keep in args.keep:
                        jobs.append(delayed(one_sample)(gt, hole, keep, args.pixels, s * 7919 + i))
                        meta.append({**base, "kind": "train", "seed": s, "keep": keep})
    print(f"{len(jobs)} samples to compute", flush=True)
    start = time.perf_counter()
    results = Parallel(n_jobs=args.jobs, verbose=2, batch_size=4)(jobs)
    print(f"computed in {time.perf_counter() - start:.0f} s", flush=True)
    for kind in ("train", "eval"):
        idx = [k for k, m in enumerate(meta) if m["kind"] == kind]
        if not idx:
            continue
        pix = {key: np.concatenate([results[k][key] for k in idx]) for key in ("x", "y", "rc")}
        pix["sample"] = np.concatenate([np.full(len(results[k]["y"]), n, np.int32) for n, k in enumerate(idx)])
        np.savez(out / f"{kind}-pixels.npz", **pix)
        shapes = {results[k]["ctx"].shape for k in idx}
        if len(shapes) != 1:
            raise SystemExit(f"context grids of several shapes {shapes}: crop the frames alike")
        np.save(out / f"{kind}-context.npy", np.stack([results[k]["ctx"] for k in idx]))
        rows = [{**meta[k], "ref": results[k]["ref"], "shape": list(results[k]["shape"])} for k in idx]
        (out / f"{kind}.json").write_text(json.dumps(rows))
    (out / "channels.json").write_text(json.dumps({"pixel": CHANNELS, "context": CONTEXT_CHANNELS,
                                                   "factor": FACTOR}))


# --------------------------------------------------------------------------- models
VARIANTS: dict[str, dict] = {
    # kitti-rect-v4's per-pixel blend (five candidates, gaps, endpoints), on these samples
    "blend": {},
    "blend-bal": {"balance": 1.0},
    # the blend plus scene context (ContextBlendInpainter), drives weighted or not
    "context": {"context": 8},
    "context-bal": {"context": 8, "balance": 1.0},
    "context-bal-frame": {"context": 8, "balance": 1.0, "loss": "frame"},
    "context-bal-short": {"context": 8, "balance": 1.0, "epochs": 2},
    "context-bal-small": {"context": 8, "balance": 1.0, "widths": (8, 16, 24, 32)},
    "context-bal-wd": {"context": 8, "balance": 1.0, "weight_decay": 1e-3},
    # the shipped recipe with other initialisation and batch seeds (members of an ensemble)
    "context-bal-s1": {"context": 8, "balance": 1.0, "seed": 1},
    "context-bal-s2": {"context": 8, "balance": 1.0, "seed": 2},
    # the context U-Net also reads each cell's height in the frame (CoordConv): where the
    # horizon and the road lie, which the scale-free channels only imply
    "context-bal-coord": {"context": 8, "balance": 1.0, "coords": True},
    # the context U-Net also predicts a coarse depth, which the blend takes as one more
    # candidate: a fill that need not come from the hole's border
    "context-bal-cand": {"context": 8, "balance": 1.0, "context_candidate": True},
}
BLEND_CANDS = ["scanline", "scanline-inverse", "vertical", "vertical-inverse", "harmonic-inverse"]
CLASSICAL = ["scanline", "scanline-inverse", "harmonic", "harmonic-inverse"]
GAPS_ENDS = ["gap-l", "gap-r", "gap-u", "gap-d", "end-l", "end-r", "end-u", "end-d"]


class Cache:
    def __init__(self, folder: Path, kind: str):
        with np.load(folder / f"{kind}-pixels.npz") as z:
            self.x, self.y, self.rc, self.sample = z["x"], z["y"], z["rc"], z["sample"]
        self.ctx = np.load(folder / f"{kind}-context.npy", mmap_mode="r")
        self.meta = json.loads((folder / f"{kind}.json").read_text())
        starts = np.searchsorted(self.sample, np.arange(len(self.meta) + 1))
        self.slices = [slice(starts[k], starts[k + 1]) for k in range(len(self.meta))]

    def pixels(self, k: int, sel: np.ndarray | None = None):
        """Channel-major ``(13, m)`` features (five candidates, gaps, endpoints), rows, cols, truth."""
        import torch

        sl = self.slices[k]
        cols = [CHANNELS.index(c) for c in [*BLEND_CANDS, *GAPS_ENDS]]
        x, y, rc = self.x[sl], self.y[sl], self.rc[sl]
        if sel is not None:
            x, y, rc = x[sel], y[sel], rc[sel]
        return (torch.from_numpy(np.ascontiguousarray(x[:, cols].T)), torch.from_numpy(rc[:, 0].astype(np.int64)),
                torch.from_numpy(rc[:, 1].astype(np.int64)), torch.from_numpy(y))

    def grids(self, picks) -> "torch.Tensor":
        """The product's context grids (:func:`estimators.learned.nets.context_blend.context_grid`): 2x2 means of the cache's 4x4 blocks."""
        import torch

        chans = [CONTEXT_CHANNELS.index(c) for c in ["obs", "density", "hole", *BLEND_CANDS]]
        t = torch.from_numpy(np.stack([np.asarray(self.ctx[k][chans], np.float32) for k in picks]))
        return torch.nn.functional.avg_pool2d(t, 2, ceil_mode=True)


class RowCoordinates(nn.Module):
    """A context U-Net that also reads each cell's height above the frame's bottom
    (0 at the bottom row of cells, 1 at the top), appended to the grid (CoordConv)."""

    def __init__(self, unet: nn.Module):
        super().__init__()
        self.inner = unet

    def forward(self, grid: torch.Tensor) -> torch.Tensor:
        n, _, h, w = grid.shape
        rows = (h - 1 - torch.arange(h, dtype=grid.dtype)) / max(h - 1, 1)
        return self.inner(torch.cat([grid, rows.view(1, 1, h, 1).expand(n, 1, h, w)], 1))


class ContextCandidateNet(nn.Module):
    """:class:`ContextBlendNet` whose context U-Net also outputs a depth per cell (log, relative
    to the frame's reference), sampled per pixel and blended as a sixth candidate."""

    def __init__(self, k: int, n_context: int, widths: tuple, width: int, layers: int):
        super().__init__()
        from estimators.learned.nets.context_blend import GRID_BASE_CHANNELS, ContextBlendNet, ContextUNet
        from estimators.learned.nets.pixel_blend import PixelBlendNet

        self.k = k
        self.context = ContextUNet(len(GRID_BASE_CHANNELS) + k, n_context + 1, widths)
        self.pixel = PixelBlendNet(k + 1, 4, width, layers, n_endpoints=4, relative=True, n_extra=n_context + 1)
        self.sample = ContextBlendNet.sample

    def mirror_order(self) -> list[int]:
        """Mirror order of the cached channels (the k classical candidates, gaps, endpoints):
        the pixel net's, without the context candidate it inserts at position k."""
        k = self.k
        return [i if i < k else i - 1 for i in self.pixel.mirror_order() if i != k]

    def blend_pixels(self, channels: torch.Tensor, context: torch.Tensor, ref) -> torch.Tensor:
        from estimators.learned.nets.pixel_blend import MIN_DEPTH

        k = self.k
        prior = torch.exp((context[-1] + ref).clamp(-5.0, 6.0))  # 0.007 m .. 400 m
        rel = torch.log(channels[:k].clamp_min(MIN_DEPTH)).mean(dim=0, keepdim=True) - ref
        ch = torch.cat([channels[:k], prior[None], channels[k:]], dim=0)
        return self.pixel.blend_channels(ch, torch.cat([context[:-1], rel], dim=0))


def make_net(variant: dict):
    from estimators.learned.nets.context_blend import GRID_BASE_CHANNELS, ContextBlendNet, ContextUNet
    from estimators.learned.nets.pixel_blend import PixelBlendNet

    k, width, layers = len(BLEND_CANDS), int(variant.get("width", 64)), int(variant.get("layers", 2))
    if variant.get("context"):
        widths = tuple(variant.get("widths", (16, 32, 48, 64)))
        if variant.get("context_candidate"):
            return ContextCandidateNet(k, int(variant["context"]), widths, width, layers)
        net = ContextBlendNet(k, int(variant["context"]), widths, width, layers)
        if variant.get("coords"):
            net.context = RowCoordinates(ContextUNet(len(GRID_BASE_CHANNELS) + k + 1, int(variant["context"]), widths))
        return net
    return PixelBlendNet(k, 4, width, layers, n_endpoints=4, relative=True)


def _predict(net, cache: Cache, k: int, context, pixels, rows, cols, flip: bool):
    if flip:
        pixels, cols = pixels[net.mirror_order()], cache.meta[k]["shape"][1] - 1 - cols
    if context is None:
        return net.blend_channels(pixels)
    return net.blend_pixels(pixels, net.sample(context, rows, cols), float(cache.meta[k]["ref"]))


def train_fold(train: Cache, idx: list[int], variant: dict, seed: int, epochs: int, batch: int = 8,
               pixels: int = 1024, lr: float = 2e-3, threads: int = 2):
    import torch

    torch.set_num_threads(threads)
    torch.manual_seed(seed)
    net = make_net(variant)
    has_context = bool(variant.get("context"))
    opt = torch.optim.Adam(net.parameters(), lr=lr, weight_decay=float(variant.get("weight_decay", 0.0)))
    batch = min(batch, len(idx))
    steps = int(variant.get("epochs", epochs)) * max(1, len(idx) // batch)
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=lr, total_steps=steps, pct_start=0.05)
    rng = np.random.default_rng(seed)
    # balance: draw samples with weight 1 / (samples of their drive) ** balance, so that
    # long drives (consecutive, near-identical frames) do not dominate the scene prior
    drives = [train.meta[k]["drive"] for k in idx]
    counts = {d: drives.count(d) for d in set(drives)}
    weights = np.array([counts[d] ** -float(variant.get("balance", 0.0)) for d in drives])
    weights /= weights.sum()
    losses = []
    t0 = time.perf_counter()
    for step in range(steps):
        picks = rng.choice(idx, batch, replace=False, p=weights)
        flip = bool(rng.random() < 0.5)
        context = None
        if has_context:
            grids = train.grids(picks)
            context = net.context(grids.flip(-1) if flip else grids)
        errs = []
        for n, k in enumerate(picks):
            m = train.slices[k].stop - train.slices[k].start
            sel = rng.choice(m, pixels, replace=False) if m > pixels else np.arange(m)
            px, rows, cols, y = train.pixels(k, sel)
            pred = _predict(net, train, k, None if context is None else context[n], px, rows, cols, flip)
            errs.append((pred - y).square())
        if variant.get("loss") == "frame":  # the metric: mean over frame-masks of the per-frame RMSE
            loss = torch.stack([e.mean().clamp_min(1e-6).sqrt() for e in errs if len(e)]).mean()
        else:
            loss = torch.cat(errs).mean()
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        sched.step()
        losses.append(float(loss.detach()))
        if (step + 1) % 200 == 0:
            print(f"    step {step + 1}/{steps} loss {np.mean(losses[-200:]):.2f} ({time.perf_counter() - t0:.0f} s)",
                  flush=True)
    net.eval()
    return net


def predict_samples(net, cache: Cache, idx: list[int], variant: dict) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Predictions of the samples ``idx``: averaged with the mirrored frame's (tta), and without."""
    import torch

    preds, plain = [], []
    with torch.inference_mode():
        for k in idx:
            px, rows, cols, _ = cache.pixels(k)
            vals = []
            for flip in (False, True):
                context = None
                if variant.get("context"):
                    g = cache.grids([k])
                    context = net.context(g.flip(-1) if flip else g)[0]
                vals.append(_predict(net, cache, k, context, px, rows, cols, flip))
            floor = 0.5 * px[: len(BLEND_CANDS)].min(0).values
            preds.append(torch.maximum(0.5 * (vals[0] + vals[1]), floor).numpy())
            plain.append(torch.maximum(vals[0], floor).numpy())
    return preds, plain


def _rmse(pred: np.ndarray, y: np.ndarray) -> float:
    return float(np.sqrt(np.mean((pred.astype(np.float64) - y) ** 2)))


def folds(meta: list[dict]) -> dict[str, tuple]:
    """name -> (train predicate, eval predicate) over sample metadata."""
    days = sorted({m["day"] for m in meta if m["split"] == "train"})
    out = {}
    for d in days:
        out[f"day {d}"] = (lambda m, d=d: m["day"] != d, lambda m, d=d: m["split"] == "train" and m["day"] == d)
    official = "2011_09_26_drive_0001_sync"
    out["drive 0001 (official)"] = (lambda m: m["drive"] != official,
                                    lambda m: m["drive"] == official)
    out["val 9101 (check)"] = (lambda m: m["drive"] != official, lambda m: m["split"] == "val")
    return out


def cmd_fit(args: argparse.Namespace) -> None:
    from inpaintenv.report.stats import bootstrap_ratio_ci

    folder = Path(args.cache)
    train, ev = Cache(folder, "train"), Cache(folder, "eval")
    keep_eval = _scored_eval(ev, args.eval_seeds)
    classical_rmse = _classical_rmse(ev)
    chosen = {n: f for n, f in folds(ev.meta).items() if not args.folds or any(s in n for s in args.folds)}
    models: dict = {}
    results: dict = {}
    fold_preds: dict[str, list] = {}

    def report(vname: str, fname: str, preds: list[np.ndarray], eidx: list[int], note: str) -> float:
        mine = np.array([_rmse(p, ev.y[ev.slices[k]]) for p, k in zip(preds, eidx)])
        means = {c: classical_rmse[c][eidx].mean() for c in CLASSICAL}
        best = min(means, key=means.get)
        ratio, lo, hi = bootstrap_ratio_ci(mine, classical_rmse[best][eidx])
        print(f"{vname:>16} | {fname:<24} | n={len(eidx):4d} | {mine.mean():6.3f} m vs {best} {means[best]:6.3f} m "
              f"| ratio {ratio:.3f} [{lo:.3f}, {hi:.3f}] | {note}", flush=True)
        return ratio

    for vname in args.variant:
        variant = VARIANTS[vname]
        for fname, (is_train, is_eval) in chosen.items():
            tidx = [k for k, m in enumerate(train.meta) if is_train(m)]
            eidx = [k for k in keep_eval if is_eval(ev.meta[k])]
            key = (vname, fname.replace(" (check)", "").startswith("val") and "drive 0001 (official)" or fname)
            seed, epochs = int(variant.get("seed", args.seed)), int(variant.get("epochs", args.epochs))
            # keyed by what trains the model, so a run with another --seed/--epochs never reads these back
            saved = (Path(args.preds) / vname / f"seed{seed}-epochs{epochs}" / f"{fname.replace(' ', '_')}.npz"
                     if args.preds else None)
            t0 = time.perf_counter()
            kind = "p" if args.no_tta else "s"  # s: averaged with the mirrored frame, p: plain
            if saved is not None and saved.exists():  # an earlier run's predictions: nothing to train
                with np.load(saved) as z:
                    preds = [z[f"{kind}{k}"] for k in eidx]
                note = f"predictions from {saved}"
            else:
                if key not in models:
                    models[key] = train_fold(train, tidx, variant, seed, args.epochs, threads=args.threads)
                both = predict_samples(models[key], ev, eidx, variant)
                preds = both[1] if args.no_tta else both[0]
                note = f"train={len(tidx):4d} | fit {time.perf_counter() - t0:.0f} s"
                if saved is not None:
                    saved.parent.mkdir(parents=True, exist_ok=True)
                    np.savez(saved, **{f"{c}{k}": p for c, ps in zip("sp", both) for k, p in zip(eidx, ps)})
            fold_preds.setdefault(fname, []).append(preds)
            results[(vname, fname)] = report(vname, fname, preds, eidx, note)
    if args.ensemble and len(args.variant) > 1:
        # the mean of the listed variants' predictions, per pixel (what an ensemble release would predict)
        name = "+".join(args.variant)
        for fname, member_preds in fold_preds.items():
            eidx = [k for k in keep_eval if chosen[fname][1](ev.meta[k])]
            mean = [np.mean(np.stack(per_sample), axis=0) for per_sample in zip(*member_preds)]
            results[(name, fname)] = report("ensemble", fname, mean, eidx, name)
    print(json.dumps({f"{v}|{f}": round(r, 4) for (v, f), r in results.items()}))


def _scored_eval(ev: Cache, seeds: list[int] | None) -> list[int]:
    """Evaluation samples to score: of ``seeds`` (all if None), with ground truth in the hole."""
    keep = [k for k, m in enumerate(ev.meta) if not seeds or m["seed"] in seeds]
    # frame-masks with no ground truth in the hole leave every mean, as in the benchmark
    return [k for k in keep if ev.slices[k].stop > ev.slices[k].start]


def _classical_rmse(ev: Cache) -> dict[str, np.ndarray]:
    """Hole RMSE of every classical candidate on every evaluation sample (NaN without ground truth)."""
    return {c: np.array([_rmse(ev.x[ev.slices[k]][:, CHANNELS.index(c)], ev.y[ev.slices[k]])
                         if ev.slices[k].stop > ev.slices[k].start else np.nan for k in range(len(ev.meta))])
            for c in CLASSICAL}


def cmd_select(args: argparse.Namespace) -> None:
    from sklearn.model_selection import GroupKFold

    from inpaintenv.report.stats import bootstrap_ratio_ci

    if args.inner < 2:
        raise SystemExit(f"--inner must be at least 2 (a GroupKFold needs two splits), got {args.inner}")
    folder = Path(args.cache)
    train, ev = Cache(folder, "train"), Cache(folder, "eval")
    keep_eval = _scored_eval(ev, args.eval_seeds)
    classical_rmse = _classical_rmse(ev)
    chosen = {n: f for n, f in folds(ev.meta).items()
              if "check" not in n and (not args.folds or any(s in n for s in args.folds))}
    summary: dict[str, dict] = {}
    for fname, (is_train, _) in chosen.items():
        tidx = np.array([k for k, m in enumerate(train.meta) if is_train(m)])
        drives = np.array([train.meta[k]["drive"] for k in tidx])
        n_drives = len(set(drives))
        if n_drives < 2:
            print(f"select | {fname}: fewer than 2 training drives, nothing to choose on", flush=True)
            continue
        splits = list(GroupKFold(n_splits=min(args.inner, n_drives)).split(tidx, groups=drives))
        scores = {}
        for vname in args.variant:
            variant = VARIANTS[vname]
            seed, epochs = int(variant.get("seed", args.seed)), int(variant.get("epochs", args.epochs))
            mine, eidx_all = [], []
            for tr, te in splits:
                held = set(drives[te])
                # the held-out drives' evaluation masks, never a frame of the fold's own report
                eidx = [k for k in keep_eval if ev.meta[k]["split"] == "train" and ev.meta[k]["drive"] in held]
                net = train_fold(train, list(tidx[tr]), variant, seed, epochs, threads=args.threads)
                preds = predict_samples(net, ev, eidx, variant)[1 if args.no_tta else 0]
                mine += [_rmse(p, ev.y[ev.slices[k]]) for p, k in zip(preds, eidx)]
                eidx_all += eidx
            means = {c: classical_rmse[c][eidx_all].mean() for c in CLASSICAL}
            best = min(means, key=means.get)
            ratio, lo, hi = bootstrap_ratio_ci(np.array(mine), classical_rmse[best][eidx_all])
            scores[vname] = ratio
            print(f"select {vname:>16} | {fname:<24} | {len(splits)} inner folds over "
                  f"{n_drives} drives | n={len(eidx_all):4d} | ratio {ratio:.3f} [{lo:.3f}, {hi:.3f}]",
                  flush=True)
        pick = min(scores, key=scores.get)
        print(f"select | {fname}: choose {pick}", flush=True)
        summary[fname] = {"choice": pick, "inner_ratio": {v: round(r, 4) for v, r in scores.items()}}
    print(json.dumps(summary))


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("cache", help="compute the per-sample features once")
    c.add_argument("--kitti-root", required=True)
    c.add_argument("--out", required=True)
    c.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    c.add_argument("--train-masks", type=int, default=3)
    c.add_argument("--train-every", type=int, default=1, help="training samples from every N-th frame")
    c.add_argument("--keep", type=float, nargs="+", default=[1.0, 0.6])
    c.add_argument("--pixels", type=int, default=3000)
    c.add_argument("--jobs", type=int, default=2)
    c.add_argument("--limit", type=int, default=None, help="at most N frames per drive and camera (quick tests)")
    # what fit and select share: the cache, the variants and folds, and how each is trained and scored
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--cache", required=True)
    common.add_argument("--variant", action="append", choices=sorted(VARIANTS), required=True)
    common.add_argument("--folds", nargs="*", default=None, help="substrings of fold names to run")
    common.add_argument("--eval-seeds", type=int, nargs="*", default=None)
    common.add_argument("--epochs", type=int, default=4)
    common.add_argument("--seed", type=int, default=0)
    common.add_argument("--threads", type=int, default=2)
    common.add_argument("--no-tta", action="store_true",
                        help="score predictions without the mirrored frame's (the flip test-time augmentation)")
    f = sub.add_parser("fit", parents=[common], help="train and score each variant per fold")
    f.add_argument("--preds", help="folder keeping each variant's predictions per fold; a variant already "
                   "there is read back, not trained (runs of single variants can go in parallel)")
    f.add_argument("--ensemble", action="store_true",
                   help="also score the mean of the listed variants' predictions per fold")
    s = sub.add_parser("select", parents=[common],
                       help="choose between variants by GroupKFold over each fold's training drives")
    s.add_argument("--inner", type=int, default=3, help="GroupKFold splits over the fold's training drives")
    args = p.parse_args(argv)
    {"cache": cmd_cache, "fit": cmd_fit, "select": cmd_select}[args.cmd](args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
