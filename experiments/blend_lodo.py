"""Leave-one-drive-out experiments for the learned blend, on cached per-pixel features.

The learned blend (:class:`estimators.prior.PriorUNetInpainter`, ``arch="pixel"``) sees,
for every pixel to fill, classical candidate fills, gap lengths and endpoint depths
(:func:`estimators.priors.prior_features`). Those features are the expensive part, so
this script computes them once per (frame, occlusion) and then trains many small MLP
variants on the cached pixels, leave-one-drive-out:

``cache``
    For every frame with ground truth of the ``train`` (and ``val``) drives of a KITTI
    root: ``--train-masks`` rect-v1 occlusions with training seeds (>= 1000, never the
    evaluation seeds) of which ``--pixels`` hole pixels with ground truth are kept, and
    the evaluation occlusions (seeds ``--seeds``, the masks the benchmark draws for
    ``--drives <drive>``) with every hole pixel with ground truth.
``fit``
    For each variant and each held-out train drive: train on the other train drives'
    training pixels, predict the held-out drive's (and the ``val`` frames') evaluation
    pixels, and print per drive the mean per-frame hole RMSE, that of the strongest
    classical candidate on the same frames, and their ratio with a paired 95 % bootstrap
    interval over frames.

This is where recipes are chosen: on the held-out drives of the folds, by drive-level
cross-validation; the shipped model is then trained by ``inpaintenv train`` on every
train drive and checked with ``inpaintenv benchmark`` (docs/model_card.md).

Examples
--------
    python experiments/blend_lodo.py cache --kitti-root <KITTI root> --out lodo-cache
    python experiments/blend_lodo.py fit --cache lodo-cache --variant base --variant thin
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
from joblib import Parallel, delayed

from estimators.priors import AVAILABLE_CANDIDATES, prior_features
from inpaintenv.data import KittiDepth
from inpaintenv.masks import get_protocol

#: Channels kept per pixel: every candidate, 4 gap lengths, 4 endpoint depths.
CHANNELS = list(AVAILABLE_CANDIDATES) + ["gap-l", "gap-r", "gap-u", "gap-d", "end-l", "end-r", "end-u", "end-d"]
TRAIN_SEED0 = 1000


def _frame_features(x: np.ndarray) -> np.ndarray:
    f = prior_features(x, AVAILABLE_CANDIDATES, gaps=True, endpoints=True)
    return f[3:]  # drop depth / hole / valid


def thin(gt: np.ndarray, hole: np.ndarray, keep: float, rng: np.random.Generator) -> np.ndarray:
    """Corrupted input with a fraction ``1 - keep`` of the measured pixels outside the hole dropped."""
    x = np.where(hole, np.nan, gt).astype(np.float32)
    drop = (gt > 0) & ~hole & (rng.random(gt.shape) > keep)
    x[drop] = 0.0
    return x


def corrupted_input(gt: np.ndarray, hole: np.ndarray, keep: float, rng: np.random.Generator) -> np.ndarray:
    """The model's input: NaN in the hole, measured pixels thinned by :func:`thin` when ``keep < 1``."""
    return thin(gt, hole, keep, rng) if keep < 1 else np.where(hole, np.nan, gt).astype(np.float32)


def hole_pixels(gt: np.ndarray, hole: np.ndarray, n_pixels: int | None,
                rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Rows and columns of the hole pixels with ground truth, at most ``n_pixels`` drawn by ``rng``."""
    rows, cols = np.nonzero(hole & (gt > 0))
    if n_pixels is not None and len(rows) > n_pixels:
        pick = np.sort(rng.choice(len(rows), n_pixels, replace=False))
        rows, cols = rows[pick], cols[pick]
    return rows, cols


def frames_by_drive(kitti_root: str) -> dict[tuple[str, str], list[np.ndarray]]:
    """Every ground-truth map of the ``train`` and ``val`` drives, keyed by (split, drive)."""
    frames = {}
    for split in ("train", "val"):
        for drive in sorted({str(g) for g in KittiDepth(kitti_root, split=split).groups}):
            ds = KittiDepth(kitti_root, split=split, drives=[drive])
            frames[(split, drive)] = ds.load_batch(range(len(ds)))
    return frames


def save_cache(out: Path, results: list[dict], meta: list[dict]) -> None:
    """One ``KIND.npz`` (each result's arrays concatenated, plus ``sample``) and ``KIND.json`` per kind."""
    for kind in sorted({m["kind"] for m in meta}):
        idx = [k for k, m in enumerate(meta) if m["kind"] == kind]
        arrays = {key: np.concatenate([results[k][key] for k in idx]) for key in results[idx[0]]}
        arrays["sample"] = np.concatenate([np.full(len(results[k]["y"]), n, np.int32) for n, k in enumerate(idx)])
        np.savez(out / f"{kind}.npz", **arrays)
        (out / f"{kind}.json").write_text(json.dumps([meta[k] for k in idx]))


def _one(gt: np.ndarray, hole: np.ndarray, n_pixels: int | None, seed: int, keep: float,
         evaluation: bool = False) -> dict:
    rng = np.random.default_rng(seed)
    feats = _frame_features(corrupted_input(gt, hole, keep, rng))
    rows, cols = hole_pixels(gt, hole, n_pixels, rng)
    return {"x": feats[:, rows, cols].T.astype(np.float32), "y": gt[rows, cols].astype(np.float32),
            "row": rows.astype(np.int16)}


def build_cache(kitti_root: str, out: Path, one, seeds: list[int], train_masks: int, keeps: list[float],
                pixels: int, n_jobs: int, train_kind=lambda keep: f"train-{keep:g}", eval_keep: float = 1.0) -> None:
    """Compute ``one(gt, hole, n_pixels, seed, keep, evaluation)`` for every frame with ground truth and save it.

    Evaluation occlusions are the benchmark's (``seeds``, every hole pixel); training ones
    use seeds from :data:`TRAIN_SEED0` and keep ``pixels`` per (occlusion, keep fraction).
    ``eval_keep < 1`` thins the evaluation inputs too (sparser maps, like the official ones).
    """
    out.mkdir(parents=True, exist_ok=True)
    protocol = get_protocol("rect-v1")
    jobs, meta = [], []
    for (split, drive), frames in frames_by_drive(kitti_root).items():
        for i, gt in enumerate(frames):
            if not (gt > 0).any():
                continue
            for s in seeds:  # the benchmark's masks for --drives <drive>
                jobs.append(delayed(one)(gt, protocol.mask(gt.shape, s, i), None, s, eval_keep, True))
                meta.append({"split": split, "drive": drive, "frame": i, "kind": "eval", "seed": s})
            if split == "train":
                for m in range(train_masks):
                    s = TRAIN_SEED0 + m
                    hole = protocol.mask(gt.shape, s, i)
                    for keep in keeps:
                        jobs.append(delayed(one)(gt, hole, pixels, s * 7 + i, keep, False))
                        meta.append({"split": split, "drive": drive, "frame": i, "kind": train_kind(keep), "seed": s})
    print(f"{len(jobs)} (frame, occlusion) feature sets to compute", flush=True)
    start = time.perf_counter()
    results = Parallel(n_jobs=n_jobs, verbose=5)(jobs)
    print(f"computed in {time.perf_counter() - start:.0f} s", flush=True)
    save_cache(out, results, meta)


def cmd_cache(args: argparse.Namespace) -> None:
    out = Path(args.out)
    build_cache(args.kitti_root, out, _one, [] if args.train_only else args.seeds, args.train_masks, args.keep,
                args.pixels, args.jobs)
    (out / "channels.json").write_text(json.dumps(CHANNELS))


#: Recipes compared by ``fit``: candidate subset, endpoint channels, row context, which
#: training inputs (``keep``: fraction of measured pixels kept), network size.
SIX = ["scanline", "scanline-inverse", "vertical", "harmonic", "vertical-inverse", "harmonic-inverse"]
FIVE = ["scanline", "scanline-inverse", "vertical", "vertical-inverse", "harmonic-inverse"]
_SMALL = {"endpoints": True, "width": 64, "layers": 2}
VARIANTS: dict[str, dict] = {
    # kitti-rect-v3's inputs (six candidates, gaps, no endpoints) at its size
    "v3-inputs": {"candidates": SIX, "endpoints": False, "keep": ["1"], "width": 128, "layers": 3},
    "six": {"candidates": SIX, "keep": ["1"], **_SMALL},
    "five": {"candidates": FIVE, "keep": ["1"], **_SMALL},
    "five-thin": {"candidates": FIVE, "keep": ["1", "0.65"], **_SMALL},
    "six-thin": {"candidates": SIX, "keep": ["1", "0.65"], **_SMALL},
    "rowctx-thin": {"candidates": FIVE + ["row-median", "row-far"], "keep": ["1", "0.65"], **_SMALL},
    "five-thin-wide": {"candidates": FIVE, "keep": ["1", "0.65"], "endpoints": True, "width": 128, "layers": 3},
    "six-thin-wide": {"candidates": SIX, "keep": ["1", "0.65"], "endpoints": True, "width": 128, "layers": 3,
                      "epochs": 8},
    "six-thin3": {"candidates": SIX, "keep": ["1", "0.65", "0.4"], **_SMALL},
    "six-thin3-wide": {"candidates": SIX, "keep": ["1", "0.65", "0.4"], "endpoints": True, "width": 128,
                       "layers": 3, "epochs": 8},
    "rowctx6-thin3": {"candidates": SIX + ["row-median", "row-far"], "keep": ["1", "0.65", "0.4"], **_SMALL},
    "six-thin3-w128x2": {"candidates": SIX, "keep": ["1", "0.65", "0.4"], "endpoints": True, "width": 128,
                         "layers": 2, "epochs": 8},
    "six-thin3-w128x2-notta": {"candidates": SIX, "keep": ["1", "0.65", "0.4"], "endpoints": True, "width": 128,
                               "layers": 2, "epochs": 8, "tta": False},
    "six-thin3-wide-nores": {"candidates": SIX, "keep": ["1", "0.65", "0.4"], "endpoints": True, "width": 128,
                             "layers": 3, "epochs": 8, "residual": False},
    "five-thin3": {"candidates": FIVE, "keep": ["1", "0.65", "0.4"], **_SMALL},
    "five-thin3-e6": {"candidates": FIVE, "keep": ["1", "0.65", "0.4"], **_SMALL, "epochs": 6},
    "five-thin3-notta": {"candidates": FIVE, "keep": ["1", "0.65", "0.4"], **_SMALL, "tta": False},
    "five-thin3-nores": {"candidates": FIVE, "keep": ["1", "0.65", "0.4"], **_SMALL, "residual": False},
    "five-harmonic-thin3": {"candidates": ["scanline", "scanline-inverse", "vertical", "vertical-inverse", "harmonic"],
                            "keep": ["1", "0.65", "0.4"], **_SMALL},
    "four-thin": {"candidates": ["scanline", "scanline-inverse", "vertical-inverse", "harmonic-inverse"],
                  "keep": ["1", "0.65"], **_SMALL},
}
CLASSICAL = ["scanline", "scanline-inverse", "harmonic", "harmonic-inverse"]


def _columns(variant: dict) -> tuple[list[int], int, int]:
    cand = [CHANNELS.index(c) for c in variant["candidates"]]
    gaps = [CHANNELS.index(c) for c in ("gap-l", "gap-r", "gap-u", "gap-d")]
    ends = [CHANNELS.index(c) for c in ("end-l", "end-r", "end-u", "end-d")] if variant["endpoints"] else []
    return cand + gaps + ends, len(cand), len(ends)


def load_cache(cache: Path, kind: str) -> tuple[dict, list[dict]]:
    with np.load(cache / f"{kind}.npz") as z:
        data = {k: z[k] for k in z.files}
    return data, json.loads((cache / f"{kind}.json").read_text())


def _estimator(variant: dict, seed: int, epochs: int):
    from estimators.blend import BlendInpainter

    return BlendInpainter(candidates=tuple(variant["candidates"]), endpoints=variant["endpoints"],
                          width=variant["width"], layers=variant["layers"], residual=variant.get("residual", True),
                          tta=variant.get("tta", True), epochs=epochs, random_state=seed)


def predict_pixels(net, x: np.ndarray, tta: bool = True) -> np.ndarray:
    """A :class:`~estimators.learned.nets.pixel_blend.PixelBlendNet`'s hole prediction on cached pixel features.

    Flip-averaged (``tta``) and floored at half the smallest candidate, as the estimator predicts.
    """
    import torch

    mirrored = net.mirror_order()
    with torch.inference_mode():
        chunks = torch.from_numpy(np.ascontiguousarray(x)).split(1 << 15)
        if tta:
            out = [0.5 * (net.blend(c) + net.blend(c[:, mirrored])) for c in chunks]
        else:
            out = [net.blend(c) for c in chunks]
        pred = torch.cat(out).numpy()
    return np.maximum(pred, 0.5 * x[:, :net.n_candidates].min(axis=1))


def _per_sample_rmse(err2: np.ndarray, sample: np.ndarray, n: int) -> np.ndarray:
    return np.sqrt(np.bincount(sample, err2, n) / np.maximum(np.bincount(sample, None, n), 1))


def _ratio_ci(a: np.ndarray, b: np.ndarray, seed: int = 0, n_boot: int = 2000) -> tuple[float, float, float]:
    rng = np.random.default_rng(seed)
    idx = rng.integers(0, len(a), (n_boot, len(a)))
    boots = a[idx].mean(1) / b[idx].mean(1)
    return float(a.mean() / b.mean()), float(np.quantile(boots, 0.025)), float(np.quantile(boots, 0.975))


def strongest(classical: dict[str, np.ndarray], sel: np.ndarray) -> str:
    """The method of ``classical`` (per-frame RMSE arrays) with the lowest mean over the frames ``sel``."""
    return min(classical, key=lambda c: classical[c][sel].mean())


def versus_strongest(learned: np.ndarray, classical: dict[str, np.ndarray],
                     sel: np.ndarray) -> tuple[str, float, float, float]:
    """:func:`strongest` on ``sel``, and ``learned``'s ratio to it with its paired 95 % interval."""
    best = strongest(classical, sel)
    return (best, *_ratio_ci(learned[sel], classical[best][sel]))


def cmd_fit(args: argparse.Namespace) -> None:
    cache = Path(args.cache)
    ev, ev_meta = load_cache(cache, "eval")
    train_sets = {}
    n_ev = len(ev_meta)
    drives_of = np.array([m["drive"] for m in ev_meta])
    split_of = np.array([m["split"] for m in ev_meta])
    train_drives = sorted(set(drives_of[split_of == "train"]))
    classical = {c: _per_sample_rmse((ev["x"][:, CHANNELS.index(c)] - ev["y"]) ** 2, ev["sample"], n_ev)
                 for c in CLASSICAL}
    results = {}
    for name in args.variant:
        variant = VARIANTS[name]
        cols, _, _ = _columns(variant)
        for keep in variant["keep"]:
            if keep not in train_sets:
                train_sets[keep] = load_cache(cache, f"train-{keep}")
        results[name] = {}
        folds = args.folds or train_drives
        for held in folds:
            xs, ys = [], []
            for keep in variant["keep"]:
                data, meta = train_sets[keep]
                ok = np.array([m["drive"] != held for m in meta])[data["sample"]]
                xs.append(data["x"][ok][:, cols])
                ys.append(data["y"][ok])
            start = time.perf_counter()
            est = _estimator(variant, args.seed, variant.get("epochs", args.epochs))
            est.model_, _ = est._fit_pixels(np.concatenate(xs), np.concatenate(ys), int(est.random_state))
            fit_s = time.perf_counter() - start
            # Only the pixels scored with this fold's model: the held-out drive's and val's.
            scored_samples = (drives_of == held) | ((split_of == "val") & args.val)
            px = scored_samples[ev["sample"]]
            pred = predict_pixels(est.model_, ev["x"][px][:, cols], est.tta)
            rmse = _per_sample_rmse((pred - ev["y"][px]) ** 2, ev["sample"][px], n_ev)
            for scored in [held] + (["val"] if args.val else []):
                sel = (drives_of == held) if scored == held else (split_of == "val")
                best, r, lo, hi = versus_strongest(rmse, classical, sel)
                label = scored if scored != "val" else f"val (model without {held})"
                results[name][label] = {"frames": int(sel.sum()), "hole_rmse": float(rmse[sel].mean()),
                                        "classical": best, "classical_rmse": float(classical[best][sel].mean()),
                                        "ratio": r, "ci": [lo, hi]}
                print(f"{name:10s} {label:48s} n={sel.sum():3d} learned {rmse[sel].mean():6.3f} m  "
                      f"{best:16s} {classical[best][sel].mean():6.3f} m  ratio {r:.3f} [{lo:.3f}, {hi:.3f}]  "
                      f"(fit {fit_s:.0f} s)", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1))


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("cache", help="compute per-pixel features of every frame once")
    c.add_argument("--kitti-root", required=True)
    c.add_argument("--out", required=True)
    c.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    c.add_argument("--train-masks", type=int, default=3)
    c.add_argument("--pixels", type=int, default=3000)
    c.add_argument("--keep", type=float, nargs="+", default=[1.0], help="fractions of measured pixels kept in training inputs")
    c.add_argument("--jobs", type=int, default=2)
    c.add_argument("--train-only", action="store_true", help="only the training pixels (e.g. another --keep)")
    f = sub.add_parser("fit", help="train variants leave-one-drive-out on the cache and score them")
    f.add_argument("--cache", required=True)
    f.add_argument("--variant", action="append", choices=list(VARIANTS), required=True)
    f.add_argument("--folds", nargs="+", help="held-out train drives (default: each in turn)")
    f.add_argument("--epochs", type=int, default=4)
    f.add_argument("--seed", type=int, default=0)
    f.add_argument("--val", action="store_true", help="also score the val frames with each fold's model")
    f.add_argument("--json", help="write the results here")
    args = p.parse_args(argv)
    {"cache": cmd_cache, "fit": cmd_fit}[args.cmd](args)


if __name__ == "__main__":
    main()
