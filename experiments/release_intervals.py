"""The interval calibration shipped with a release: out-of-fold residuals of its leave-one-day-out fold models.

The release saw every drive of the slice, so no drive can calibrate it directly. Its three
fold models (the release's recipe, each trained without one recording day and a few
calibration drives: docs/model_card.md, "Per-pixel intervals") can: every drive is scored by
the fold model trained without that drive's whole day, and
``ConformalIntervalInpainter.fit_out_of_fold`` fits the scale and the quantiles on those
pooled residuals, then wraps the release. The result is written to
``estimators/pretrained/intervals/<release>.json`` (``--out`` to write elsewhere).

    python experiments/release_intervals.py --kitti-root <KITTI root> \
        --fold 2011_09_26=<model without 2011_09_26> --fold 2011_09_30=<...> --fold 2011_10_03=<...>

A release that was trained on a few drives only (``kitti-mixed-v1``: frames of one drive) needs
no fold models: without ``--fold`` it is calibrated directly on every drive its
``training_drives_`` does not name, with its own masks protocol (``--protocol``)::

    python experiments/release_intervals.py --kitti-root <KITTI root> --release kitti-mixed-v1 --protocol mixed-v1

A classical fill (``--release scanline``) saw no drive: it is calibrated the same way, on every
drive, and ships as ``<name>-intervals``::

    python experiments/release_intervals.py --kitti-root <KITTI root> --release scanline --spread-method nearest
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

import numpy as np


def main(argv: list[str] | None = None) -> Path:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--kitti-root", required=True)
    parser.add_argument("--release", default="kitti-ensemble-v1", help="a shipped release or a classical fill")
    parser.add_argument("--fold", action="append", default=[], metavar="DAY=MODEL",
                        help="a fold model trained without every drive of recording day DAY (repeatable)")
    parser.add_argument("--frames-per-drive", type=int, default=12, help="0 = every frame")
    parser.add_argument("--spread-method", default="scanline")
    parser.add_argument("--coverage", type=float, default=0.9)
    parser.add_argument("--protocol", default="rect-v1", help="masks protocol the calibration frames are occluded with")
    parser.add_argument("--out", help="default estimators/pretrained/intervals/<release>.json")
    args = parser.parse_args(argv)

    from estimators.intervals import ConformalIntervalInpainter
    from estimators.learned import load
    from inpaintenv.data import KittiDepth, spaced_per_drive
    from inpaintenv.registry import make_method

    dataset = KittiDepth(args.kitti_root, split="train")
    drives = sorted({str(g) for g in dataset.groups})
    folds = []
    for entry in args.fold:
        day, _, path = entry.partition("=")
        model = load(path)
        mine = [d for d in drives if d.startswith(day)]
        if not mine:
            raise SystemExit(f"--fold {entry}: no drive of day {day!r} in {args.kitti_root}")
        folds.append((model, spaced_per_drive(dataset, args.frames_per_drive, mine)))
        print(f"{day}: {len(mine)} drives scored by {path}", flush=True)
    release = make_method(args.release)
    start = time.perf_counter()
    wrapper = ConformalIntervalInpainter(release, coverage=args.coverage, spread_method=args.spread_method,
                                         protocol=args.protocol)
    if folds:
        left = sorted(set(drives) - {str(g) for _, ds in folds for g in ds.groups})
        if left:
            raise SystemExit(f"no fold scores drives {left}: give a --fold for their day")
        wrapper.fit_out_of_fold(folds)
    else:
        unseen = sorted(set(drives) - set(getattr(release, "training_drives_", None) or ()))
        if not unseen:
            raise SystemExit(f"{args.release} saw every drive of {args.kitti_root}: give its fold models (--fold)")
        wrapper.fit(spaced_per_drive(dataset, args.frames_per_drive, unseen))
    out = Path(args.out) if args.out else (Path(__file__).resolve().parents[1] / "estimators" / "pretrained"
                                           / "intervals" / f"{args.release}.json")
    wrapper.save(out, base=args.release)
    cal = wrapper.calibration_
    print(f"{out}: {len(cal['drives'])} drives, {cal['n_frames']} frames, {cal['n_pixels']} pixels, "
          f"q = {wrapper.quantile_:.3f} at {cal['coverage']}, coef {np.round(wrapper.coef_, 3).tolist()} "
          f"({time.perf_counter() - start:.0f} s)")
    return out


if __name__ == "__main__":
    main()
