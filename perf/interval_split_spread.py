"""How far a calibrated interval's coverage lands from its target by chance alone, on real KITTI.

A leave-one-day-out fold (``interval_lodo.py``) scores the drives of one recording day, 3 to
6 here. Even if every drive were exchangeable with every other, the coverage measured on so
few drives scatters around the target, because the drives, not the pixels, are the units
that vary. This script measures that scatter: the residuals of a classical fill (it never saw
any drive) are computed once per drive, then ``--splits`` random splits put
``--test-drives`` drives aside for scoring and calibrate ``ConformalIntervalInpainter`` on
all the others, once per ``weighting``. Each split's coverage is the mean over its scored
frames of the share of hole pixels (with truth) inside the interval, as the benchmark's
``hole_coverage`` is. Printed per weighting and number of scored drives: the mean coverage,
its standard deviation over splits, the 5-95 % range and the share of splits inside
``--band``; then each recording day left out, with its rank among the random splits of
its size (a day outside that range errs in a way random drives do not).

    python perf/interval_split_spread.py --kitti-root <KITTI root> [--frames-per-drive 6]

The intervals are the wrapper's own (its ``_residuals`` and ``_calibrate``), so a split's
coverage is what ``evaluate(..., intervals=C)`` reports for the same calibration and frames.
Each drive's frames are occluded as a dataset of their own (masks 0, 1, ... of
``--protocol``), so a split's calibration is ``fit``'s on the same drives up to the masks drawn.
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np


def drive_residuals(wrapper: Any, dataset: Any, drives: list[str], frames_per_drive: int) -> dict[str, tuple]:
    """``{drive: (F, r, frame)}``: the wrapper's signals, absolute residuals and frame numbers per drive."""
    from inpaintenv.data import spaced_per_drive

    wrapper._check_params()
    signals = tuple(wrapper.signals)
    second = wrapper._second_fill(wrapper.spread_method) if "spread" in signals else None
    out = {}
    for drive in drives:
        F, r, frame = wrapper._residuals(wrapper.estimator, spaced_per_drive(dataset, frames_per_drive, [drive]),
                                         signals, second)
        out[drive] = (F, r, frame)
    return out


def split_coverage(wrapper: Any, residuals: dict[str, tuple], calibrate_on: list[str],
                   score_on: list[str]) -> float:
    """Calibrate ``wrapper`` on the residuals of ``calibrate_on``; mean per-frame coverage on ``score_on``."""
    signals = tuple(wrapper.signals)
    parts = [residuals[d] for d in calibrate_on]
    offsets = np.cumsum([0] + [int(p[2].max()) + 1 for p in parts[:-1]])  # frame numbers distinct across drives
    wrapper._calibrate(np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts]),
                       np.concatenate([p[2] + o for p, o in zip(parts, offsets)]), None, sorted(calibrate_on),
                       signals, n_frames=int(sum(int(p[2].max()) + 1 for p in parts)))
    per_frame = []
    for drive in score_on:
        F, r, frame = residuals[drive]
        inside = r <= wrapper.quantile_ * wrapper._scale_from(F)
        per_frame.extend(np.bincount(frame, weights=inside)[np.unique(frame)] / np.bincount(frame)[np.unique(frame)])
    return float(np.mean(per_frame))


def summarise(coverages: np.ndarray, band: tuple[float, float]) -> dict[str, float]:
    """Mean, standard deviation, 5 and 95 % points and the share inside ``band`` of split coverages."""
    return {"mean": float(coverages.mean()), "sd": float(coverages.std(ddof=1)) if coverages.size > 1 else 0.0,
            "p05": float(np.quantile(coverages, 0.05)), "p95": float(np.quantile(coverages, 0.95)),
            "in_band": float(np.mean((coverages >= band[0]) & (coverages <= band[1])))}


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--kitti-root", required=True)
    parser.add_argument("--method", default="scanline", help="registered classical fill to wrap")
    parser.add_argument("--spread-method", default="harmonic")
    parser.add_argument("--signals", nargs="*", default=["border", "depth", "spread"])
    parser.add_argument("--coverage", type=float, default=0.9)
    parser.add_argument("--protocol", default="rect-v1")
    parser.add_argument("--frames-per-drive", type=int, default=6, help="0 = every frame")
    parser.add_argument("--test-drives", type=int, nargs="+", default=[3, 6], help="scored drives per split")
    parser.add_argument("--splits", type=int, default=200)
    parser.add_argument("--band", type=float, nargs=2, default=[0.87, 0.93])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", help="also write the summary here")
    args = parser.parse_args(argv)

    from estimators.intervals import WEIGHTINGS, ConformalIntervalInpainter
    from inpaintenv.data import KittiDepth
    from inpaintenv.methods.registry import make_method

    start = time.perf_counter()
    dataset = KittiDepth(args.kitti_root, split="train")
    drives = sorted({str(g) for g in dataset.groups})
    if max(args.test_drives) >= len(drives):
        raise SystemExit(f"--test-drives must leave a drive to calibrate on: the slice has {len(drives)} drives")
    wrappers = {w: ConformalIntervalInpainter(make_method(args.method), coverage=args.coverage,
                                              signals=tuple(args.signals), spread_method=args.spread_method,
                                              protocol=args.protocol, weighting=w) for w in WEIGHTINGS}
    residuals = drive_residuals(wrappers["frame"], dataset, drives, args.frames_per_drive)
    rng = np.random.default_rng(args.seed)
    splits = {k: [sorted(rng.choice(drives, k, replace=False)) for _ in range(args.splits)] for k in args.test_drives}
    days = sorted({d[:10] for d in drives})
    summary: dict[str, Any] = {"drives": len(drives), "frames_per_drive": args.frames_per_drive,
                               "splits": args.splits, "band": args.band, "random": {}, "days": {}}
    print(f"{len(drives)} drives, {args.frames_per_drive or 'all'} frames each; coverage of the "
          f"{args.coverage:.0%} interval around {args.method}, {args.splits} random splits\n\n"
          "| weighting | scored drives | mean | sd | 5-95 % | splits in band |\n|---|---:|---:|---:|---|---:|")
    random_coverages = {}
    for weighting, wrapper in wrappers.items():
        for k, chosen in splits.items():
            cov = np.array([split_coverage(wrapper, residuals, [d for d in drives if d not in s], s) for s in chosen])
            random_coverages[weighting, k] = cov
            row = summarise(cov, tuple(args.band))
            summary["random"][f"{weighting}/{k}"] = dict(row, coverages=cov.tolist())
            print(f"| {weighting} | {k} | {row['mean']:.3f} | {row['sd']:.3f} | {row['p05']:.3f}-{row['p95']:.3f} | "
                  f"{row['in_band']:.0%} |")
    print("\n| day left out | scored drives | weighting | coverage | share of random splits of that size below |"
          "\n|---|---:|---|---:|---:|")
    for day in days:
        scored = [d for d in drives if d[:10] == day]
        for weighting, wrapper in wrappers.items():
            cov = split_coverage(wrapper, residuals, [d for d in drives if d[:10] != day], scored)
            k = len(scored)
            same_size = random_coverages.get((weighting, k))
            rank = float(np.mean(same_size < cov)) if same_size is not None else float("nan")
            summary["days"][f"{day}/{weighting}"] = {"coverage": cov, "scored_drives": k, "rank": rank}
            print(f"| {day} | {k} | {weighting} | {cov:.3f} | "
                  f"{'-' if np.isnan(rank) else f'{rank:.0%}'} |")
    summary["seconds"] = time.perf_counter() - start
    print(f"\n({summary['seconds']:.0f} s)")
    if args.json:
        from inpaintenv.files import write_json
        write_json(args.json, summary)
    return summary


if __name__ == "__main__":
    main()
