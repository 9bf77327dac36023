"""Prediction speed of the shipped learned model (``estimators.learned.load_release``).

Times ``predict`` on one KITTI-sized frame with a ``rect-v1`` hole and splits it into
its two parts: the classical candidate fills (NumPy/OpenCV, ``prior_features``) and the
per-pixel network (``PixelBlendNet``, run on every unmeasured pixel, twice with the
left-right flip average). Input is in memory, so PNG decoding is not part of the figure.

Examples
--------
    python perf/bench_pretrained.py                      # kitti-mixed-v1, synthetic frame
    python perf/bench_pretrained.py --kitti-root <KITTI root> --name kitti-mixed-v1
    python perf/bench_pretrained.py --chunk 8192 --chunk 262144   # network chunk sizes

Timing is the median over ``--repeat`` runs after one warm-up run.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

import numpy as np
import torch

import estimators.learned.nets.pixel_blend as pixel_blend
from estimators.learned import load_release

#: The shipped release of this class.
DEFAULT_PRETRAINED = "kitti-mixed-v1"
from inpaintenv.data import KittiDepth, SyntheticStreets
from inpaintenv.masks import get_protocol


def _median_ms(fn, repeat: int) -> float:
    fn()  # warm-up
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return 1000 * statistics.median(times)


def main(argv: list[str] | None = None) -> dict:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--name", default=DEFAULT_PRETRAINED, help=f"shipped release (default {DEFAULT_PRETRAINED})")
    p.add_argument("--kitti-root", help="score a real frame (first frame of the split) instead of a synthetic one")
    p.add_argument("--repeat", type=int, default=5, help="timed runs (default 5)")
    p.add_argument("--threads", type=int, default=2, help="torch threads (default 2)")
    p.add_argument("--chunk", type=int, action="append", help="network chunk size(s) in pixels (default: the shipped CHUNK)")
    args = p.parse_args(argv)
    if args.repeat < 1 or args.threads < 1:
        p.error("--repeat and --threads must be >= 1")

    torch.set_num_threads(args.threads)
    gt = KittiDepth(args.kitti_root)[0] if args.kitti_root else SyntheticStreets(n=1, seed=0)[0]
    hole = get_protocol("rect-v1").masks(gt.shape, 0, [0])[0]
    x = np.where(hole, np.nan, gt).astype(np.float32)
    est = load_release(args.name, num_threads=args.threads)

    features_ms = _median_ms(lambda: est._features(x[None]), args.repeat)
    results = {"name": args.name, "frame": list(gt.shape), "threads": args.threads,
               "unmeasured_pixels": int((~(x > 0)).sum()), "features_ms": round(features_ms, 1), "predict_ms": {}}
    default_chunk = pixel_blend.CHUNK
    try:
        for chunk in args.chunk or [default_chunk]:
            pixel_blend.CHUNK = chunk
            results["predict_ms"][chunk] = round(_median_ms(lambda: est.predict(x), args.repeat), 1)
    finally:
        pixel_blend.CHUNK = default_chunk
    print(json.dumps(results, indent=1))
    return results


if __name__ == "__main__":
    main()
