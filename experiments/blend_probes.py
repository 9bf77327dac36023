"""Probes of what limits the learned blend, leave-one-drive-out (issue 15's directions).

The shipped blend (``kitti-rect-v4``, :class:`estimators.blend.BlendInpainter`) chooses,
per pixel, between classical candidate fills. Three questions, each answered by drive-level
cross-validation on the ``train`` drives (9101, the official frame, is a check only):

``oracle``
    How far can choosing go? Per drive, the hole RMSE of the best candidate per *pixel*
    and per *frame*, chosen with hindsight, ÷ the strongest single classical fill.
``cache`` + ``fit --variant svh|svhv``
    Self-validation at test time: hide the measured pixels of copies of each hole
    component shifted by its own width left and right (``svh``; ``svhv`` adds copies
    shifted up and down), fill them with every candidate, and give the blend each
    candidate's log-depth RMSE there (relative to the best one, plus the best one's and
    a "probe had > 20 pixels" flag) as per-pixel inputs.
``fit`` (every variant)
    Also prints each fold's *gate oracle*: the blend or the strongest classical fill,
    whichever is better per frame with hindsight, ÷ the strongest classical fill (the
    ceiling of a learned gate that falls back to the classical fill where unsure).
``fit --far-weight W``
    Training pixels whose depth is beyond 40 m weigh ``1 + W`` in the loss (more
    weight on the far scene, which the official maps hold more of).

``fit --variant base`` is the shipped recipe (five candidates, gap lengths, endpoint
depths, 64×2 MLP, inputs thinned to 100 / 65 / 40 %, 3 epochs) on the same cache, so
every row of a run is comparable.

Examples
--------
    python experiments/blend_probes.py cache --kitti-root <KITTI root> --out probe-cache
    python experiments/blend_probes.py oracle --cache probe-cache
    python experiments/blend_probes.py fit --cache probe-cache --variant base --variant svh --variant svhv
    python experiments/blend_probes.py fit --cache probe-cache --variant base --far-weight 1 --far-weight 3
    python experiments/blend_probes.py time --kitti-root <KITTI root>
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import cv2
import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parent))
from blend_lodo import (
    _per_sample_rmse,
    build_cache,
    corrupted_input,
    hole_pixels,
    load_cache,
    predict_pixels,
    strongest,
    versus_strongest,
)

from estimators.blend import BLEND_CANDIDATES
from estimators.learned.nets.pixel_blend import GAP_SCALE, MIN_DEPTH, PixelBlendNet
from estimators.priors import candidate_fills, prior_features
from inpaintenv.data import KittiDepth
from inpaintenv.masks import get_protocol

K = len(BLEND_CANDIDATES)
#: Cached columns: K candidates, 4 gaps, 4 endpoints; self-validation (K + 2) x 2
#: directions; for evaluation pixels, the harmonic fill of depth (a classical baseline).
BASE = list(range(K + 8))
SV_H = list(range(K + 8, 2 * K + 10))
SV_V = list(range(2 * K + 10, 3 * K + 12))
HARMONIC = 3 * K + 12
VARIANTS = {"base": [], "svh": SV_H, "svhv": SV_H + SV_V}
#: The classical methods scored beside the blend (columns of the cache).
CLASSICAL = {"scanline": 0, "scanline-inverse": 1, "harmonic": HARMONIC, "harmonic-inverse": 4}
MIN_PROBE_PIXELS = 20
KEEP = (1.0, 0.65, 0.4)


def probe_regions(hole: np.ndarray, direction: str = "h", margin: float = 0.0,
                  min_margin: int = 0) -> tuple[np.ndarray, np.ndarray, int]:
    """Copies of each hole component shifted by its own size (plus a margin), outside the hole.

    Parameters
    ----------
    hole : numpy.ndarray
        ``(H, W)`` bool.
    direction : {"h", "v"}
        Shift by the component's width left and right, or by its height up and down.
    margin, min_margin : float, int
        Shift further by ``margin`` x that size, at least ``min_margin`` pixels (default 0:
        the copies touch the hole), so that measured pixels stay between hole and copy.

    Returns
    -------
    probe : numpy.ndarray
        ``(H, W)`` int32: ``i`` on the probe pixels of component ``i`` (1-based), else 0.
    labels : numpy.ndarray
        ``(H, W)`` int32 component of each hole pixel (0 outside the hole).
    n : int
        Components + 1 (label 0 is the background).
    """
    if direction not in ("h", "v"):
        raise ValueError(f"direction must be 'h' or 'v', got {direction!r}")
    n, labels, stats, _ = cv2.connectedComponentsWithStats(hole.astype(np.uint8), connectivity=8)
    h, w = hole.shape
    probe = np.zeros(hole.shape, np.int32)
    for i in range(1, n):
        x0, y0, bw, bh, _ = stats[i]
        comp = labels[y0:y0 + bh, x0:x0 + bw] == i
        sx = bw + max(int(min_margin), round(margin * bw))
        sy = bh + max(int(min_margin), round(margin * bh))
        for dy, dx in ([(0, sx), (0, -sx)] if direction == "h" else [(sy, 0), (-sy, 0)]):
            top, left = y0 + dy, x0 + dx
            r0, r1, c0, c1 = max(top, 0), min(top + bh, h), max(left, 0), min(left + bw, w)
            if r0 < r1 and c0 < c1:
                probe[r0:r1, c0:c1][comp[r0 - top:r1 - top, c0 - left:c1 - left]] = i
    probe[hole] = 0
    return probe, labels, n


def self_validation(x: np.ndarray, names: tuple[str, ...] = BLEND_CANDIDATES, direction: str = "h") -> np.ndarray:
    """Per-hole-component scores of the candidates on hidden measured pixels nearby.

    Returns ``(len(names) + 2, H, W)`` float32, non-zero on hole pixels only: each
    candidate's log(RMSE of log depth + 0.01) minus the best candidate's, the best one's,
    and 1 where the probe held more than :data:`MIN_PROBE_PIXELS` measurements (else all 0).
    """
    hole = np.isnan(x)
    probe, labels, n = probe_regions(hole, direction)
    k = len(names)
    out = np.zeros((k + 2, *x.shape), np.float32)
    scored = (probe > 0) & (np.nan_to_num(x) > 0)
    if not scored.any():
        return out
    cands = candidate_fills(np.where(probe > 0, np.nan, x), names)
    which, truth = probe[scored], x[scored]
    count = np.bincount(which, minlength=n).astype(np.float64)
    err = np.stack([np.sqrt(np.bincount(which, np.log(np.maximum(c[scored], MIN_DEPTH) / truth) ** 2, minlength=n)
                            / np.maximum(count, 1)) for c in cands], axis=1)
    log_err = np.log(err + 0.01)
    table = np.zeros((n, k + 2), np.float32)
    table[:, :k] = log_err - log_err.min(axis=1, keepdims=True)
    table[:, k] = log_err.min(axis=1)
    table[:, k + 1] = 1.0
    table[count <= MIN_PROBE_PIXELS] = 0.0
    table[0] = 0.0  # background
    out[:] = table[labels].transpose(2, 0, 1)
    return out


def _one(gt: np.ndarray, hole: np.ndarray, n_pixels: int | None, seed: int, keep: float, evaluation: bool) -> dict:
    rng = np.random.default_rng(seed)
    x = corrupted_input(gt, hole, keep, rng)
    parts = [prior_features(x, BLEND_CANDIDATES, gaps=True, endpoints=True)[3:],
             self_validation(x, BLEND_CANDIDATES, "h"), self_validation(x, BLEND_CANDIDATES, "v")]
    if evaluation:
        parts.append(candidate_fills(x, ["harmonic"]))
    feats = np.concatenate(parts)
    rows, cols = hole_pixels(gt, hole, n_pixels, rng)
    return {"x": feats[:, rows, cols].T.astype(np.float32), "y": gt[rows, cols].astype(np.float32)}


def cmd_cache(args: argparse.Namespace) -> None:
    build_cache(args.kitti_root, Path(args.out), _one, args.seeds, args.train_masks, list(KEEP), args.pixels,
                args.jobs, train_kind=lambda keep: "train", eval_keep=args.eval_keep)


class ExtraInputBlend(PixelBlendNet):
    """:class:`PixelBlendNet` (relative, endpoints) with ``n_extra`` raw inputs after the endpoints."""

    def __init__(self, n_extra: int, width: int = 64, layers: int = 2):
        super().__init__(K, 4, width, layers, n_endpoints=4, relative=True)
        self.n_extra = n_extra
        self.body[0] = torch.nn.Linear(K + 8 + n_extra, width)

    def mirror_order(self) -> list[int]:
        return super().mirror_order() + list(range(K + 8, K + 8 + self.n_extra))  # extras are mirror-invariant

    def blend_channels(self, channels: torch.Tensor) -> torch.Tensor:
        channels = channels.contiguous()
        cands = channels[:K]
        log_c = torch.log(cands.clamp_min(MIN_DEPTH))
        log_ref = log_c.mean(dim=0, keepdim=True)
        ends = channels[K + 4:K + 8]
        log_e = torch.where(ends > 0, torch.log(ends.clamp_min(MIN_DEPTH)) - log_ref, 0.0)
        z = torch.cat([log_c - log_ref, torch.log1p(channels[K:K + 4]) / GAP_SCALE, log_e, channels[K + 8:]], dim=0)
        out = self.head(self.body(z.T)).T
        return (torch.softmax(out[:K], dim=0) * cands).sum(dim=0) + torch.exp(log_ref[0]) * out[K]


def fit_pixels(x: np.ndarray, y: np.ndarray, n_extra: int, seed: int = 0, epochs: int = 3, far_weight: float = 0.0,
               lr: float = 2e-3, batch: int = 8192) -> ExtraInputBlend:
    """Train like ``BlendInpainter._fit_pixels`` (Adam, one-cycle, flip augmentation), optionally far-weighted."""
    torch.manual_seed(seed)
    net = ExtraInputBlend(n_extra)
    rng = np.random.default_rng([seed, 0x5EED])
    per_epoch = max(1, len(y) // batch)
    optimizer = torch.optim.Adam(net.parameters(), lr=lr)
    schedule = torch.optim.lr_scheduler.OneCycleLR(optimizer, max_lr=lr, total_steps=per_epoch * epochs,
                                                   pct_start=0.05)
    xt, yt = torch.from_numpy(np.ascontiguousarray(x, np.float32)), torch.from_numpy(y)
    weight = 1.0 + far_weight * (yt > 40.0).float()
    mirrored = net.mirror_order()
    for _ in range(epochs):
        for idx in torch.from_numpy(rng.permutation(len(y))[: per_epoch * batch]).split(batch):
            xb = xt[idx][:, mirrored] if rng.random() < 0.5 else xt[idx]
            loss = (weight[idx] * (net.blend(xb) - yt[idx]).square()).sum() / weight[idx].sum()
            optimizer.zero_grad(set_to_none=True)
            loss.backward()
            optimizer.step()
            schedule.step()
    return net.eval()


def _groups(meta: list[dict]) -> np.ndarray:
    return np.array([m["drive"] for m in meta])


def _classical(ev: dict, n: int) -> dict[str, np.ndarray]:
    return {c: _per_sample_rmse((ev["x"][:, col] - ev["y"]) ** 2, ev["sample"], n) for c, col in CLASSICAL.items()}


def _has_pixels(ev: dict, n: int) -> np.ndarray:
    return np.bincount(ev["sample"], minlength=n) > 0


def cmd_oracle(args: argparse.Namespace) -> dict:
    ev, meta = load_cache(Path(args.cache), "eval")
    n, drives = len(meta), _groups(meta)
    ok = _has_pixels(ev, n)
    classical = _classical(ev, n)
    columns = list(range(K)) + [HARMONIC]
    err2 = np.stack([(ev["x"][:, c] - ev["y"]) ** 2 for c in columns], axis=1)
    per_pixel = _per_sample_rmse(err2.min(axis=1), ev["sample"], n)
    per_frame = np.min([_per_sample_rmse(e, ev["sample"], n) for e in err2.T], axis=0)
    out = {}
    for drive in sorted(set(drives)):
        sel = (drives == drive) & ok
        best = strongest(classical, sel)
        ref = classical[best][sel].mean()
        out[drive] = {"frames": int(sel.sum()), "classical": best, "classical_rmse": float(ref),
                      "pixel_oracle": float(per_pixel[sel].mean() / ref),
                      "frame_oracle": float(per_frame[sel].mean() / ref)}
        print(f"{drive:30s} n={sel.sum():3d} strongest {best:16s} {ref:6.3f} m  per-pixel oracle "
              f"{out[drive]['pixel_oracle']:.3f}  per-frame oracle {out[drive]['frame_oracle']:.3f}", flush=True)
    return out


def cmd_fit(args: argparse.Namespace) -> dict:
    cache = Path(args.cache)
    ev, ev_meta = load_cache(cache, "eval")
    train, train_meta = load_cache(cache, "train")
    n, drives = len(ev_meta), _groups(ev_meta)
    ok = _has_pixels(ev, n)
    val = np.array([m["split"] == "val" for m in ev_meta])
    classical = _classical(ev, n)
    train_drive = _groups(train_meta)[train["sample"]]
    results: dict[str, dict] = {}
    for name in args.variant:
        for far_weight in args.far_weight or [0.0]:
            label = name if not far_weight else f"{name} far-weight {far_weight:g}"
            results[label] = {}
            cols = BASE + VARIANTS[name]
            for held in sorted(set(drives[~val])):
                start = time.perf_counter()
                use = train_drive != held
                net = fit_pixels(train["x"][use][:, cols], train["y"][use], len(VARIANTS[name]), args.seed,
                                 args.epochs, far_weight)
                fit_s = time.perf_counter() - start
                for scored, sel in ((held, drives == held), (f"val (model without {held})", val)):
                    sel = sel & ok
                    px = sel[ev["sample"]]
                    rmse = _per_sample_rmse((predict_pixels(net, ev["x"][px][:, cols]) - ev["y"][px]) ** 2,
                                            ev["sample"][px], n)
                    best, r, lo, hi = versus_strongest(rmse, classical, sel)
                    # The ceiling of any gate that falls back to the strongest classical fill:
                    # per frame, the better of the two, chosen with hindsight.
                    gate = np.minimum(rmse[sel], classical[best][sel]).mean() / classical[best][sel].mean()
                    results[label][scored] = {"frames": int(sel.sum()), "hole_rmse": float(rmse[sel].mean()),
                                              "classical": best, "ratio": r, "ci": [lo, hi],
                                              "gate_oracle": float(gate)}
                    print(f"{label:24s} {scored:48s} n={sel.sum():3d} learned {rmse[sel].mean():6.3f} m  "
                          f"{best:16s} {classical[best][sel].mean():6.3f} m  ratio {r:.3f} [{lo:.3f}, {hi:.3f}]  "
                          f"gate oracle {gate:.3f}  (fit {fit_s:.0f} s)", flush=True)
    return results


def cmd_time(args: argparse.Namespace) -> dict:
    """Milliseconds per frame of the blend's features and of one direction's self-validation."""
    ds = KittiDepth(args.kitti_root, split="train", drives=[args.drive])
    protocol = get_protocol("rect-v1")
    times: dict[str, list[float]] = {"features_ms": [], "self_validation_h_ms": []}
    for i in range(min(args.frames, len(ds))):
        gt = ds[i]
        x = np.where(protocol.mask(gt.shape, 0, i), np.nan, gt).astype(np.float32)
        self_validation(x)  # warm-up
        for key, work, kwargs in (("features_ms", prior_features, {"gaps": True, "endpoints": True}),
                                  ("self_validation_h_ms", self_validation, {"direction": "h"})):
            start = time.perf_counter()
            work(x, BLEND_CANDIDATES, **kwargs)
            times[key].append(round(1000 * (time.perf_counter() - start), 1))
    print(json.dumps(times))
    return times


def main(argv: list[str] | None = None) -> dict | None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("cache", help="per-pixel features, self-validation included, of every frame once")
    c.add_argument("--kitti-root", required=True)
    c.add_argument("--out", required=True)
    c.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    c.add_argument("--train-masks", type=int, default=3)
    c.add_argument("--pixels", type=int, default=3000)
    c.add_argument("--jobs", type=int, default=2)
    c.add_argument("--eval-keep", type=float, default=1.0,
                   help="fraction of measured pixels kept in the evaluation inputs (default: all)")
    o = sub.add_parser("oracle", help="best candidate per pixel / per frame with hindsight, per drive")
    o.add_argument("--cache", required=True)
    f = sub.add_parser("fit", help="train variants leave-one-drive-out and score them")
    f.add_argument("--cache", required=True)
    f.add_argument("--variant", action="append", choices=list(VARIANTS), required=True)
    f.add_argument("--far-weight", type=float, action="append", help="extra loss weight beyond 40 m (repeatable)")
    f.add_argument("--epochs", type=int, default=3)
    f.add_argument("--seed", type=int, default=0)
    f.add_argument("--json", help="write the results here")
    t = sub.add_parser("time", help="ms per frame of the blend's features and of self-validation")
    t.add_argument("--kitti-root", required=True)
    t.add_argument("--drive", default="2011_09_26_drive_9002_sync")
    t.add_argument("--frames", type=int, default=4)
    args = p.parse_args(argv)
    result = {"cache": cmd_cache, "oracle": cmd_oracle, "fit": cmd_fit, "time": cmd_time}[args.cmd](args)
    if getattr(args, "json", None):
        Path(args.json).write_text(json.dumps(result, indent=1))
    return result


if __name__ == "__main__":
    main()
