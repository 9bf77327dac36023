"""Self-validation at test time: score every method on measured pixels beside the hole, then mix.

A learned model trained on other days loses to a classical fill on some new scenes (open
country on 2011_10_03, where the row scanline carries the far depth across the hole) and
wins on others; the hindsight per-frame gate's ceiling is about 0.72x on every day
(docs/reference/selection.md). Whether a frame is one of the losing ones can be measured
from the input alone: hide measured pixels of copies of each hole component shifted left
and right by its width plus a margin (*probes*), fill them with every method exactly as the
hole is filled (hole and probes hidden together), and compare each method with the truth
there. This script measures how much of that ceiling the probes recover.

``collect``
    For every frame-mask of the held-out drives (the masks ``inpaintenv benchmark --drives
    ...`` draws, seeds ``--seed``): each method's prediction of the hole from the benchmark's
    input, and of the probes from the input with the probes hidden too. Per hole component it
    keeps the sufficient statistics of a linear mix of the methods on the hole's and on the
    probes' pixels with ground truth (``P^T P``, ``P^T t``, ``t^T t``, count), so any mix can
    be scored exactly afterwards.
``score``
    Per fold (one ``collect`` file), the mean per-frame hole RMSE of each rule ÷ the
    strongest classical method's on the same frame-masks, with a paired 95 % interval:

    * each method alone, and the hindsight per-frame choice among them (``oracle``);
    * ``gate``: per frame, the method with the lowest RMSE on the probes;
    * ``gate-comp``: the same per hole component;
    * ``inverse-mse``: per frame, methods weighted by 1 / their mean squared error on the probes;
    * ``lsq``: per frame, the non-negative weights summing to one that fit the probes best;
    * ``shrink-T``: ``lsq`` pulled toward the learned method alone, with the weight of ``T``
      probe pixels on it (``--shrink T``, several allowed).

    The rules without a parameter need no selection; a ``shrink`` strength must be chosen
    on folds other than the one it is reported on (with several files and ``--shrink``, each
    fold's choice made on the other folds is printed). Last, whether the probes rank the
    methods as the hole does: the correlation, over frame-masks, of the learned method's log
    RMSE ratio to the best other method on the probes and in the hole.

Examples
--------
    python experiments/probe_gate.py collect --kitti-root <KITTI root> --day 2011_09_30 \\
        lodo-ens/train-day-2011_09_30-ensemble-kitti/model -m scanline -m harmonic \\
        --out probe-gate/day-2011_09_30.npz
    python experiments/probe_gate.py score probe-gate/*.npz --shrink 2000 --shrink 20000
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from itertools import product
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from blend_lodo import _ratio_ci
from blend_probes import probe_regions
from focal_probe import load_method

from inpaintenv.conventions import corrupt
from inpaintenv.data import open_source
from inpaintenv.masks import get_protocol

OFFICIAL = "2011_09_26_drive_0001_sync"
#: Probe pixels with ground truth below which a component's probes are not trusted.
MIN_PROBE_PIXELS = 50


def _stats(preds: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """``[P^T P (k*k), P^T t (k), t^T t, n]`` of predictions ``(k, n)`` against ``truth`` ``(n,)``."""
    p = preds.astype(np.float64)
    t = truth.astype(np.float64)
    return np.concatenate([(p @ p.T).ravel(), p @ t, [t @ t, len(t)]])


def component_stats(preds: list[np.ndarray], gt: np.ndarray, region: np.ndarray, n: int) -> np.ndarray:
    """Per component ``1..n - 1`` of ``region`` (int labels): :func:`_stats` over its pixels with ground truth."""
    k = len(preds)
    out = np.zeros((max(n - 1, 0), k * k + k + 2))
    scored = (region > 0) & (gt > 0)
    lab = region[scored]
    stacked = np.stack([p[scored] for p in preds])
    truth = gt[scored]
    for i in range(1, n):
        sel = lab == i
        if sel.any():
            out[i - 1] = _stats(stacked[:, sel], truth[sel])
    return out


def fold_drives(kitti_root: str, day: str | None, drive: str | None) -> list[str]:
    source = open_source(kitti_root, split="train")
    drives = sorted({str(g) for g in source.groups})
    held = [d for d in drives if d.startswith(day)] if day else [drive]
    if not held or (drive and drive not in drives):
        raise SystemExit(f"no train drive matches {day or drive!r} in {kitti_root}")
    return held


def collect(methods: list[tuple[str, Any]], source: Any, seeds: list[int], protocol: str = "rect-v1",
            margin: float = 0.25, progress: bool = True) -> dict[str, Any]:
    """Hole and probe statistics of every method on every (seed, frame) of ``source``."""
    proto = get_protocol(protocol)
    k = len(methods)
    hole_rows, single_rows, probe_rows, index = [], [], [], []
    start = time.perf_counter()
    for seed, i in product(seeds, range(len(source))):
        gt = np.asarray(source[i], np.float32)
        hole = proto.mask(gt.shape, seed, i)
        # measured pixels between hole and probe keep the hole's own border (and its fill)
        probes, labels, n = probe_regions(hole, "h", margin=margin, min_margin=8)
        x = corrupt(gt, hole)
        xp = x.copy()
        xp[probes > 0] = np.nan
        on_hole = [np.asarray(m.predict(x), np.float32) for _, m in methods]
        on_probes = [np.asarray(m.predict(xp), np.float32) for _, m in methods]
        hole_rows.append(component_stats(on_hole, gt, labels, n))
        single_rows.append(component_stats(on_probes, gt, labels, n))
        probe_rows.append(component_stats(on_probes, gt, probes, n))
        index.append((seed, i, n - 1))
        if progress and len(index) % 20 == 0:
            print(f"{len(index)} frame-masks, {time.perf_counter() - start:.0f} s", flush=True)
    def stack(rows: list[np.ndarray]) -> np.ndarray:
        return np.concatenate(rows) if rows else np.zeros((0, k * k + k + 2))

    return {"methods": [name for name, _ in methods], "k": k, "index": np.array(index, np.int64).reshape(-1, 3),
            "hole": stack(hole_rows), "hole_single": stack(single_rows), "probe": stack(probe_rows)}


# ------------------------------------------------------------------ scoring
def _unpack(s: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    return (s[..., : k * k].reshape(*s.shape[:-1], k, k), s[..., k * k: k * k + k], s[..., -2], s[..., -1])


def sse(s: np.ndarray, w: np.ndarray, k: int) -> np.ndarray:
    """Sum of squared errors of the mix ``w`` (``(..., k)``) from statistics ``s`` (``(..., k*k+k+2)``)."""
    g, c, tt, _ = _unpack(s, k)
    return np.einsum("...i,...ij,...j->...", w, g, w) - 2 * np.einsum("...i,...i->...", w, c) + tt


def simplex_lsq(g: np.ndarray, c: np.ndarray, prior: np.ndarray | None = None, strength: float = 0.0) -> np.ndarray:
    """Weights ``w >= 0``, ``sum(w) = 1`` minimising ``w^T g w - 2 w^T c + strength |w - prior|^2``.

    Exact for small ``k``: the best unconstrained-on-the-face solution over every subset of
    methods (the optimum lies in the relative interior of one face of the simplex).
    """
    k = len(c)
    if strength > 0:
        g = g + strength * np.eye(k)
        c = c + strength * prior
    best, best_w = np.inf, np.eye(k)[0]
    for mask in range(1, 2 ** k):
        idx = [j for j in range(k) if mask >> j & 1]
        gs, cs = g[np.ix_(idx, idx)], c[idx]
        # minimise w^T gs w - 2 w^T cs subject to 1^T w = 1 (KKT system)
        kkt = np.zeros((len(idx) + 1, len(idx) + 1))
        kkt[:-1, :-1] = 2 * gs
        kkt[:-1, -1] = 1
        kkt[-1, :-1] = 1
        rhs = np.concatenate([2 * cs, [1.0]])
        try:
            sol = np.linalg.solve(kkt, rhs)[:-1]
        except np.linalg.LinAlgError:
            continue
        if (sol < -1e-12).any():
            continue
        w = np.zeros(k)
        w[idx] = np.maximum(sol, 0)
        w /= w.sum()
        val = w @ g @ w - 2 * w @ c
        if val < best:
            best, best_w = val, w
    return best_w


def frame_groups(index: np.ndarray) -> np.ndarray:
    """Frame-mask number of every component row."""
    return np.repeat(np.arange(len(index)), index[:, 2])


def per_frame(values: np.ndarray, index: np.ndarray) -> np.ndarray:
    """Component rows ``values`` (``(rows, ...)``) summed per frame-mask (``(frames, ...)``)."""
    out = np.zeros((len(index), *values.shape[1:]))
    np.add.at(out, frame_groups(index), values)
    return out


def method_rmse(stats: np.ndarray, k: int) -> np.ndarray:
    """``(n, k)``: each method's RMSE from statistics ``(n, k*k+k+2)``; NaN where they count no pixel."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.stack([np.sqrt(np.maximum(sse(stats, np.tile(np.eye(k)[j], (len(stats), 1)), k), 0) / stats[:, -1])
                         for j in range(k)], 1)


def rule_weights(data: dict[str, Any], rule: str, learned: int, strength: float = 0.0) -> np.ndarray:
    """Per component row, the weights of the methods under ``rule`` (frame rules repeat per component)."""
    k = int(data["k"])
    probe = data["probe"]
    one = np.eye(k)[learned]
    if rule == "gate-comp":
        out = np.tile(one, (len(probe), 1))
        ok = probe[:, -1] >= MIN_PROBE_PIXELS
        out[ok] = np.eye(k)[method_rmse(probe[ok], k).argmin(1)]
        return out
    frame_probe = per_frame(probe, data["index"])
    ok = frame_probe[:, -1] >= MIN_PROBE_PIXELS
    mse = method_rmse(frame_probe, k) ** 2
    weights = np.tile(one, (len(frame_probe), 1))
    g, c, _, _ = _unpack(frame_probe, k)
    for f in np.nonzero(ok)[0]:
        if rule == "gate":
            weights[f] = np.eye(k)[mse[f].argmin()]
        elif rule == "inverse-mse":
            inv = 1.0 / np.maximum(mse[f], 1e-9)
            weights[f] = inv / inv.sum()
        elif rule in ("lsq", "shrink"):
            weights[f] = simplex_lsq(g[f], c[f], one, strength if rule == "shrink" else 0.0)
        else:
            raise ValueError(f"unknown rule {rule!r}")
    return weights[frame_groups(data["index"])]


def frame_rmse(data: dict[str, Any], weights: np.ndarray) -> np.ndarray:
    """Per frame-mask hole RMSE of the per-component mixes ``weights``; NaN where the hole holds no truth."""
    k = int(data["k"])
    err = per_frame(sse(data["hole"], weights, k), data["index"])
    cnt = per_frame(data["hole"][:, -1], data["index"])
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.sqrt(np.maximum(err, 0) / cnt)


def probe_agreement(data: dict[str, Any], learned: int = 0) -> dict[str, float]:
    """Do the probes tell where the learned method wins? Per frame-mask with ground truth in the
    hole and at least :data:`MIN_PROBE_PIXELS` on the probes: the correlation of
    ``log(learned RMSE / best other method's RMSE)`` on the probes with the same in the hole,
    and the share of frame-masks the learned method wins (beats every other method) in each."""
    k = int(data["k"])
    totals = {region: per_frame(data[region], data["index"]) for region in ("hole", "probe")}
    rmse = {region: method_rmse(t, k) for region, t in totals.items()}
    ok = np.isfinite(rmse["hole"]).all(1) & (totals["probe"][:, -1] >= MIN_PROBE_PIXELS)
    if ok.sum() < 2 or k < 2:  # nothing to correlate, or no other method
        return {"n": int(ok.sum()), "correlation": float("nan"), "learned_wins_hole": float("nan"),
                "learned_wins_probes": float("nan")}
    others = [j for j in range(k) if j != learned]
    floor = 1e-6  # an exact fill (RMSE 0) on a synthetic frame
    log_ratio = {r: np.log(np.maximum(e[ok, learned], floor) / np.maximum(e[ok][:, others].min(1), floor))
                 for r, e in rmse.items()}
    return {"n": int(ok.sum()), "correlation": float(np.corrcoef(log_ratio["hole"], log_ratio["probe"])[0, 1]),
            "learned_wins_hole": float((log_ratio["hole"] < 0).mean()),
            "learned_wins_probes": float((log_ratio["probe"] < 0).mean())}


def subset(s: np.ndarray, k: int, idx: list[int]) -> np.ndarray:
    """Statistics ``s`` of ``k`` methods restricted to the methods ``idx``."""
    g, c, tt, n = _unpack(s, k)
    g = g[..., idx, :][..., :, idx]
    return np.concatenate([g.reshape(*s.shape[:-1], -1), c[..., idx], tt[..., None], n[..., None]], axis=-1)


def score(data: dict[str, Any], learned: str | None = None, shrinks: tuple[float, ...] = (),
          use: list[str] | None = None, single_pass: bool = False) -> dict[str, Any]:
    """Ratio ÷ the strongest classical method for every method, the oracle and every rule.

    ``use`` restricts the methods the rules mix (the learned one always among them); the
    strongest classical method is the strongest of every collected one either way.
    ``single_pass`` scores the rules' holes from the same predictions as the probes (hole
    and probes hidden together: one prediction per frame) instead of the benchmark's input.
    """
    names = list(data["methods"])
    k = len(names)
    learned = learned or names[0]
    each = method_rmse(per_frame(data["hole"], data["index"]), k)
    single = {name: each[:, j] for j, name in enumerate(names)}
    ok = np.all([np.isfinite(v) for v in single.values()], axis=0)
    classical = [n for n in names if n != learned]
    strongest = min(classical, key=lambda n: single[n][ok].mean())
    base = single[strongest][ok]
    rows = {name: single[name][ok] for name in names}
    rows["oracle"] = np.min([single[n][ok] for n in names], axis=0)
    idx = [names.index(learned)] + [names.index(n) for n in (use or names) if n != learned]
    mixed = {"index": data["index"], "k": len(idx), "probe": subset(data["probe"], k, idx),
             "hole": subset(data["hole_single" if single_pass else "hole"], k, idx)}
    if single_pass:
        rows[f"{learned} (single pass)"] = method_rmse(per_frame(mixed["hole"], mixed["index"]), len(idx))[ok, 0]
    for rule in ("gate", "gate-comp", "inverse-mse", "lsq"):
        rows[rule] = frame_rmse(mixed, rule_weights(mixed, rule, 0))[ok]
    for t in shrinks:
        rows[f"shrink-{t:g}"] = frame_rmse(mixed, rule_weights(mixed, "shrink", 0, t))[ok]
    return {"strongest": strongest, "n": int(ok.sum()), "learned": learned, "mixed": [names[j] for j in idx],
            "agreement": probe_agreement(mixed),
            "ratios": {name: _ratio_ci(v, base) for name, v in rows.items()},
            "rmse": {name: float(v.mean()) for name, v in rows.items()}}


def load(path: str | Path) -> dict[str, Any]:
    """A file written by ``collect``."""
    if not Path(path).is_file():
        raise SystemExit(f"{path}: no such file (write it with `probe_gate.py collect ... --out {path}`)")
    with np.load(path, allow_pickle=False) as f:
        data = {key: f[key] for key in f.files}
    data["methods"] = [str(m) for m in data["methods"]]
    data["k"] = int(data["k"])
    return data


def cmd_collect(args: argparse.Namespace) -> None:
    held = fold_drives(args.kitti_root, args.day, args.drive)
    camera = "both" if args.drive == OFFICIAL else args.camera
    source = open_source(args.kitti_root, split="train", camera=camera, drives=held)
    methods = [load_method(spec) for spec in [args.model, *args.method]]
    names = [name for name, _ in methods]
    print(f"{len(source)} frames of {len(held)} drives x seeds {args.seed}; methods {names}", flush=True)
    data = collect(methods, source, args.seed, margin=args.margin)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    np.savez(out, **{k: v for k, v in data.items() if k != "methods"}, methods=np.array(names))
    print(f"wrote {out}")


def cmd_score(args: argparse.Namespace) -> dict[str, Any]:
    results = {}
    for path in args.files:
        res = score(load(path), shrinks=tuple(args.shrink), use=args.use, single_pass=args.single_pass)
        results[Path(path).stem] = res
        print(f"\n{Path(path).stem}: {res['n']} frame-masks, learned {res['learned']}, strongest classical "
              f"{res['strongest']} ({res['rmse'][res['strongest']]:.2f} m); rules mix {res['mixed']}")
        print("| rule | hole RMSE (m) | ÷ strongest classical [paired 95 %] |\n|---|---:|---:|")
        for name, (r, lo, hi) in res["ratios"].items():
            print(f"| {name} | {res['rmse'][name]:.2f} | {r:.3f} [{lo:.2f}, {hi:.2f}] |")
        a = res["agreement"]
        print(f"probes vs hole, {a['n']} frame-masks: correlation of log(learned / best other) {a['correlation']:.2f}; "
              f"learned best in the hole on {a['learned_wins_hole']:.0%}, on the probes on {a['learned_wins_probes']:.0%}")
    if args.shrink and len(results) > 1:
        print("\nshrink strength chosen on the other folds (lowest mean ratio there):")
        for fold in results:
            others = [r for f, r in results.items() if f != fold]
            best = min(args.shrink, key=lambda t: np.mean([r["ratios"][f"shrink-{t:g}"][0] for r in others]))
            print(f"  {fold}: shrink-{best:g} -> {results[fold]['ratios'][f'shrink-{best:g}'][0]:.3f}")
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1))
    return results


def main(argv: list[str] | None = None) -> Any:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("collect", help="hole and probe statistics of every method on a fold's frames")
    c.add_argument("model", help="the learned method: a saved model folder or a registry name")
    c.add_argument("-m", "--method", action="append", default=[], help="classical methods to mix with (registry)")
    c.add_argument("--kitti-root", required=True)
    where = c.add_mutually_exclusive_group(required=True)
    where.add_argument("--day", help="score every train drive of this recording day")
    where.add_argument("--drive", help="score this train drive (both cameras for drive 0001)")
    c.add_argument("--camera", default="image_02")
    c.add_argument("--seed", type=int, action="append", default=None)
    c.add_argument("--margin", type=float, default=0.25, help="gap between hole and probe, x the hole's width")
    c.add_argument("--out", required=True)
    s = sub.add_parser("score", help="ratios of every rule per collected fold")
    s.add_argument("files", nargs="+")
    s.add_argument("--shrink", type=float, action="append", default=[])
    s.add_argument("--use", action="append", default=None, help="methods the rules mix (default: all)")
    s.add_argument("--single-pass", action="store_true",
                   help="holes from the predictions that also fill the probes (one prediction per frame)")
    s.add_argument("--json")
    args = p.parse_args(argv)
    if args.cmd == "collect":
        args.seed = args.seed or [0, 1]
        return cmd_collect(args)
    return cmd_score(args)


if __name__ == "__main__":
    main()
