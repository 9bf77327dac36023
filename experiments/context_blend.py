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

Examples
--------
    python experiments/context_blend.py cache --kitti-root <KITTI root> --out ctx-cache
    python experiments/context_blend.py fit --cache ctx-cache --variant blend --variant context
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
from joblib import Parallel, delayed

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
def _torch():
    import torch
    from torch import nn
    return torch, nn


def build_nets(n_cand: int, n_ctx_in: int, variant: dict):
    """(context CNN or None, pixel MLP) for a variant."""
    torch, nn = _torch()

    def block(a: int, b: int) -> nn.Module:
        return nn.Sequential(nn.Conv2d(a, b, 3, padding=1), nn.GroupNorm(4, b), nn.ReLU(inplace=True),
                             nn.Conv2d(b, b, 3, padding=1), nn.GroupNorm(4, b), nn.ReLU(inplace=True))

    class ContextUNet(nn.Module):
        def __init__(self, cin: int, cout: int, widths: tuple[int, ...]):
            super().__init__()
            self.down = nn.ModuleList()
            prev = cin
            for w in widths:
                self.down.append(block(prev, w))
                prev = w
            self.up = nn.ModuleList(block(widths[i + 1] + widths[i], widths[i]) for i in range(len(widths) - 1))
            self.head = nn.Conv2d(widths[0], cout, 1)

        def forward(self, x):
            h, w = x.shape[-2:]
            m = 2 ** (len(self.down) - 1)
            x = torch.nn.functional.pad(x, (0, (-w) % m, 0, (-h) % m), mode="replicate")
            skips = []
            for i, d in enumerate(self.down):
                x = d(x if i == 0 else torch.nn.functional.avg_pool2d(x, 2))
                skips.append(x)
            for i in reversed(range(len(self.up))):
                x = torch.nn.functional.interpolate(x, size=skips[i].shape[-2:], mode="bilinear", align_corners=False)
                x = self.up[i](torch.cat([x, skips[i]], 1))
            return self.head(x)[..., :h, :w]

    n_feat = int(variant.get("context", 0))
    cnn = ContextUNet(n_ctx_in, n_feat, tuple(variant.get("widths", (16, 32, 48, 64)))) if n_feat else None
    width, layers = int(variant.get("width", 64)), int(variant.get("layers", 2))
    dims = [n_cand + 8 + n_feat + (1 if n_feat else 0)] + [width] * layers
    mods = []
    for a, b in zip(dims[:-1], dims[1:]):
        mods += [nn.Linear(a, b), nn.ReLU(inplace=True)]
    head = nn.Linear(width, n_cand + 1)
    nn.init.zeros_(head.weight)
    nn.init.zeros_(head.bias)
    mlp = nn.Sequential(*mods, head)
    return cnn, mlp


def blend_pixels(mlp, feats, ctx_feats, frame_ref, n_cand: int):
    """Scale-free blend of ``feats`` ``(P, n_cand + 8)`` (candidates, gaps, endpoints; metres, pixels)."""
    torch, _ = _torch()
    cands = feats[:, :n_cand]
    log_c = torch.log(cands.clamp_min(1e-3))
    log_ref = log_c.mean(1, keepdim=True)
    gaps = torch.log1p(feats[:, n_cand:n_cand + 4]) / 7.0
    ends = feats[:, n_cand + 4:n_cand + 8]
    log_e = torch.where(ends > 0, torch.log(ends.clamp_min(1e-3)) - log_ref, torch.zeros_like(ends))
    parts = [log_c - log_ref, gaps, log_e]
    if ctx_feats is not None:
        parts += [ctx_feats, log_ref - frame_ref]
    out = mlp(torch.cat(parts, 1))
    blend = (torch.softmax(out[:, :n_cand], 1) * cands).sum(1)
    return blend + torch.exp(log_ref[:, 0]) * out[:, n_cand]


MIRROR = {"gap-l": "gap-r", "gap-r": "gap-l", "end-l": "end-r", "end-r": "end-l"}


def sample_context(cnn_out, rc, sample, width: int, cell: int, flip: bool):
    """Bilinear context features at full-resolution pixels ``rc`` of samples ``sample``.

    The context map has one cell per ``cell`` x ``cell`` pixels of the frame (the last
    row and column of cells may overhang it); ``width`` is the frame's width in pixels.
    """
    torch, _ = _torch()
    b, _, hh, ww = cnn_out.shape
    r = rc[:, 0].float()
    c = rc[:, 1].float()
    if flip:
        c = width - 1 - c
    # grid_sample, align_corners=False: -1 and 1 are the outer edges of the map
    gy = (r + 0.5) / (hh * cell) * 2 - 1
    gx = (c + 0.5) / (ww * cell) * 2 - 1
    out = []
    for s in range(b):
        sel = sample == s
        grid = torch.stack([gx[sel], gy[sel]], 1)[None, None]
        out.append(torch.nn.functional.grid_sample(cnn_out[s:s + 1], grid, mode="bilinear",
                                                   padding_mode="border", align_corners=False)[0, :, 0].T)
    return torch.cat(out)


VARIANTS: dict[str, dict] = {
    "blend": {},
    "context": {"context": 8},
    "context-coord": {"context": 8, "coords": True},
    "context-wide": {"context": 16, "widths": (24, 48, 64, 96)},
    "context-p2": {"context": 8, "pool": 2, "widths": (16, 32, 48, 64)},
    "context-p2-coord": {"context": 8, "pool": 2, "coords": True},
    "blend-bal": {"balance": 1.0},
    "context-p2-bal": {"context": 8, "pool": 2, "balance": 1.0},
    "context-p2-bal-small": {"context": 8, "pool": 2, "balance": 1.0, "widths": (8, 16, 24, 32)},
    "context-p2-bal-half": {"context": 8, "pool": 2, "balance": 0.5},
}
BLEND_CANDS = ["scanline", "scanline-inverse", "vertical", "vertical-inverse", "harmonic-inverse"]
CLASSICAL = ["scanline", "scanline-inverse", "harmonic", "harmonic-inverse"]


class Cache:
    def __init__(self, folder: Path, kind: str):
        with np.load(folder / f"{kind}-pixels.npz") as z:
            self.x, self.y, self.rc, self.sample = z["x"], z["y"], z["rc"], z["sample"]
        self.ctx = np.load(folder / f"{kind}-context.npy", mmap_mode="r")
        self.meta = json.loads((folder / f"{kind}.json").read_text())
        starts = np.searchsorted(self.sample, np.arange(len(self.meta) + 1))
        self.slices = [slice(starts[k], starts[k + 1]) for k in range(len(self.meta))]


def _columns(cands: list[str]) -> list[int]:
    return [CHANNELS.index(c) for c in cands] + [CHANNELS.index(c) for c in
                                                  ("gap-l", "gap-r", "gap-u", "gap-d", "end-l", "end-r", "end-u", "end-d")]


def context_input(ctx: np.ndarray, variant: dict):
    torch, _ = _torch()
    t = torch.from_numpy(np.asarray(ctx, np.float32))
    chans = [CONTEXT_CHANNELS.index(c) for c in ["obs", "density", "hole", *variant.get("ctx_cands", BLEND_CANDS)]]
    t = t[:, chans]
    if variant.get("coords"):
        n, _, h, w = t.shape
        rows = torch.linspace(-1, 1, h).view(1, 1, h, 1).expand(n, 1, h, w)
        cols = torch.linspace(-1, 1, w).view(1, 1, 1, w).expand(n, 1, h, w)
        t = torch.cat([t, rows, cols.abs()], 1)  # |col|: mirror-symmetric
    pool = int(variant.get("pool", 1))
    if pool > 1:
        t = torch.nn.functional.avg_pool2d(t, pool, ceil_mode=True)
    return t


def train_fold(train: Cache, idx: list[int], variant: dict, seed: int, epochs: int, batch: int = 8,
               pixels: int = 1024, lr: float = 2e-3, threads: int = 2):
    torch, _ = _torch()
    torch.set_num_threads(threads)
    cands = variant.get("candidates", BLEND_CANDS)
    cols = _columns(cands)
    mirror_cols = [cols[[CHANNELS[c] for c in cols].index(MIRROR.get(CHANNELS[c], CHANNELS[c]))] for c in cols]
    n_ctx = len(context_input(train.ctx[:1], variant)[0])
    torch.manual_seed(seed)
    cnn, mlp = build_nets(len(cands), n_ctx, variant)
    params = list(mlp.parameters()) + (list(cnn.parameters()) if cnn else [])
    opt = torch.optim.Adam(params, lr=lr)
    steps = epochs * max(1, len(idx) // batch)
    sched = torch.optim.lr_scheduler.OneCycleLR(opt, max_lr=lr, total_steps=steps, pct_start=0.05)
    rng = np.random.default_rng(seed)
    width = train.meta[0]["shape"][1]
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
        xs, ys, rcs, ss = [], [], [], []
        for n, k in enumerate(picks):
            sl = train.slices[k]
            m = sl.stop - sl.start
            sel = sl.start + (rng.choice(m, pixels, replace=False) if m > pixels else np.arange(m))
            xs.append(train.x[sel][:, mirror_cols if flip else cols])
            ys.append(train.y[sel])
            rcs.append(train.rc[sel])
            ss.append(np.full(len(sel), n))
        x = torch.from_numpy(np.concatenate(xs))
        y = torch.from_numpy(np.concatenate(ys))
        ctx_feats = frame_ref = None
        if cnn is not None:
            inp = context_input(np.stack([train.ctx[k] for k in picks]), variant)
            if flip:
                inp = inp.flip(-1)
            out = cnn(inp)
            rc = torch.from_numpy(np.concatenate(rcs).astype(np.int64))
            s = torch.from_numpy(np.concatenate(ss))
            # the context grid was flipped: sample it at the mirrored column
            ctx_feats = sample_context(out, rc, s, width, FACTOR * int(variant.get("pool", 1)), flip)
            frame_ref = torch.tensor([train.meta[k]["ref"] for k in picks], dtype=torch.float32)[s][:, None]
        pred = blend_pixels(mlp, x, ctx_feats, frame_ref, len(cands))
        loss = (pred - y).square().mean()
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()
        sched.step()
        losses.append(float(loss.detach()))
        if (step + 1) % 200 == 0:
            print(f"    step {step + 1}/{steps} loss {np.mean(losses[-200:]):.2f} m² "
                  f"({time.perf_counter() - t0:.0f} s)", flush=True)
    return cnn, mlp


def predict_samples(cnn, mlp, cache: Cache, idx: list[int], variant: dict) -> list[np.ndarray]:
    torch, _ = _torch()
    cands = variant.get("candidates", BLEND_CANDS)
    cols = _columns(cands)
    mirror_cols = [cols[[CHANNELS[c] for c in cols].index(MIRROR.get(CHANNELS[c], CHANNELS[c]))] for c in cols]
    preds = []
    with torch.inference_mode():
        for k in idx:
            sl = cache.slices[k]
            width = cache.meta[k]["shape"][1]
            vals = []
            for flip in (False, True):
                x = torch.from_numpy(cache.x[sl][:, mirror_cols if flip else cols])
                ctx_feats = frame_ref = None
                if cnn is not None:
                    inp = context_input(cache.ctx[k:k + 1], variant)
                    if flip:
                        inp = inp.flip(-1)
                    out = cnn(inp)
                    rc = torch.from_numpy(cache.rc[sl].astype(np.int64))
                    ctx_feats = sample_context(out, rc, torch.zeros(len(rc), dtype=torch.long), width,
                                                 FACTOR * int(variant.get("pool", 1)), flip)
                    frame_ref = torch.full((len(rc), 1), cache.meta[k]["ref"])
                vals.append(blend_pixels(mlp, x, ctx_feats, frame_ref, len(cands)))
            v = 0.5 * (vals[0] + vals[1])
            floor = 0.5 * torch.from_numpy(cache.x[sl][:, [CHANNELS.index(c) for c in cands]]).min(1).values
            preds.append(torch.maximum(v, floor).numpy())
    return preds


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
    from inpaintenv.stats import bootstrap_ratio_ci

    folder = Path(args.cache)
    train, ev = Cache(folder, "train"), Cache(folder, "eval")
    if args.eval_seeds:
        keep_eval = [k for k, m in enumerate(ev.meta) if m["seed"] in args.eval_seeds]
    else:
        keep_eval = list(range(len(ev.meta)))
    # frame-masks with no ground truth in the hole leave every mean, as in the benchmark
    keep_eval = [k for k in keep_eval if ev.slices[k].stop > ev.slices[k].start]
    classical_rmse = {c: np.array([_rmse(ev.x[ev.slices[k]][:, CHANNELS.index(c)], ev.y[ev.slices[k]])
                                   if ev.slices[k].stop > ev.slices[k].start else np.nan
                                   for k in range(len(ev.meta))]) for c in CLASSICAL}
    chosen = {n: f for n, f in folds(ev.meta).items() if not args.folds or any(s in n for s in args.folds)}
    models = {}
    results = {}
    for vname in args.variant:
        variant = VARIANTS[vname]
        for fname, (is_train, is_eval) in chosen.items():
            tidx = [k for k, m in enumerate(train.meta) if is_train(m)]
            eidx = [k for k in keep_eval if is_eval(ev.meta[k])]
            key = (vname, fname.replace(" (check)", "").startswith("val") and "drive 0001 (official)" or fname)
            t0 = time.perf_counter()
            if key not in models:
                models[key] = train_fold(train, tidx, variant, args.seed, args.epochs, threads=args.threads)
            fit_s = time.perf_counter() - t0
            preds = predict_samples(*models[key], ev, eidx, variant)
            mine = np.array([_rmse(p, ev.y[ev.slices[k]]) for p, k in zip(preds, eidx)])
            means = {c: classical_rmse[c][eidx].mean() for c in CLASSICAL}
            best = min(means, key=means.get)
            ratio, lo, hi = bootstrap_ratio_ci(mine, classical_rmse[best][eidx])
            results[(vname, fname)] = ratio
            print(f"{vname:>16} | {fname:<24} | n={len(eidx):4d} train={len(tidx):4d} | {mine.mean():6.3f} m vs "
                  f"{best} {means[best]:6.3f} m | ratio {ratio:.3f} [{lo:.3f}, {hi:.3f}] | fit {fit_s:.0f} s",
                  flush=True)
    print(json.dumps({f"{v}|{f}": round(r, 4) for (v, f), r in results.items()}))


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
    f = sub.add_parser("fit", help="train and score each variant per fold")
    f.add_argument("--cache", required=True)
    f.add_argument("--variant", action="append", choices=sorted(VARIANTS), required=True)
    f.add_argument("--folds", nargs="*", default=None, help="substrings of fold names to run")
    f.add_argument("--eval-seeds", type=int, nargs="*", default=None)
    f.add_argument("--epochs", type=int, default=4)
    f.add_argument("--seed", type=int, default=0)
    f.add_argument("--threads", type=int, default=2)
    args = p.parse_args(argv)
    {"cache": cmd_cache, "fit": cmd_fit}[args.cmd](args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
