"""Prediction time of a learned blend release beside harmonic, on 352x1216 frames.

The goal of the shipped learned model is ``predict`` <= 0.3 s per KITTI frame on two
CPU cores and <= 4x the time of ``harmonic`` measured in the same run. This script
times both on the same in-memory frames with a rect-v1 hole (PNG decoding excluded),
one frame per call, and splits the blend's time into its candidate features
(``prior_features``) and the network on the pixels to fill (an ensemble's networks, which
share one set of features, together).

Examples
--------
    python perf/bench_blend.py                                   # synthetic frames
    python perf/bench_blend.py --kitti-root <KITTI root> --frames 8
    python perf/bench_blend.py --model runs/blend/model          # a trained folder
    python perf/bench_blend.py --name kitti-ensemble-v1          # a shipped release of the blend family

Times are medians over ``--frames`` frames (each predicted ``--repeat`` times, the
fastest kept) after one warm-up call.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time

import numpy as np

from estimators.classical import HarmonicInpainter
from estimators.learned import load, load_release
from inpaintenv.methods.learned import DEFAULT_RELEASE
from estimators.candidates import prior_features
from inpaintenv.data import KittiDepth, SyntheticStreets
from inpaintenv.masks import get_protocol


def _best_ms(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return 1000 * min(times)


def main(argv: list[str] | None = None) -> dict:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--name", default=DEFAULT_RELEASE, help=f"shipped release (default {DEFAULT_RELEASE})")
    p.add_argument("--model", help="a model folder written by a blend estimator's save (instead of --name)")
    p.add_argument("--kitti-root", help="real frames (every frame with ground truth, spread over the train split)")
    p.add_argument("--frames", type=int, default=4, help="frames timed (default 4)")
    p.add_argument("--repeat", type=int, default=3, help="calls per frame; the fastest counts (default 3)")
    p.add_argument("--threads", type=int, help="torch threads of the blend's network (default: the model's "
                   "predict_threads, 1 for the shipped release)")
    args = p.parse_args(argv)
    if args.frames < 1 or args.repeat < 1 or (args.threads is not None and args.threads < 1):
        p.error("--frames, --repeat and --threads must be >= 1")

    if args.kitti_root:
        ds = KittiDepth(args.kitti_root, split="train")
        picks = np.linspace(0, len(ds) - 1, 4 * args.frames).astype(int)
        frames = [f for f in ds.load_batch(picks) if (f > 0).any()][: args.frames]
    else:
        frames = list(SyntheticStreets(n=args.frames, seed=0).load_batch(range(args.frames)))
    protocol = get_protocol("rect-v1")
    inputs = [np.where(protocol.mask(f.shape, 0, i), np.nan, f).astype(np.float32) for i, f in enumerate(frames)]
    est = load(args.model) if args.model else load_release(args.name)
    if args.threads is not None:
        est.set_params(predict_threads=args.threads)
    harmonic = HarmonicInpainter()
    # An ensemble's members share one set of features: time those of its first member.
    reader = est.estimators_[0] if hasattr(est, "estimators_") else est
    names = tuple(reader.candidates)
    est.predict(inputs[0])  # warm-up (thread pools, allocator)
    rows = []
    for x in inputs:
        rows.append({
            "blend_ms": _best_ms(lambda x=x: est.predict(x), args.repeat),
            "features_ms": _best_ms(lambda x=x: prior_features(x, names, gaps=True, endpoints=reader.endpoints),
                                    args.repeat),
            "harmonic_ms": _best_ms(lambda x=x: harmonic.predict(x), args.repeat),
            "pixels_to_fill": int(np.isnan(x).sum()),
        })
    med = {k: round(statistics.median(r[k] for r in rows), 1) for k in rows[0]}
    result = {
        "model": args.model or args.name, "frame": list(frames[0].shape), "frames": len(rows),
        "predict_threads": est.predict_threads, "cores": os.cpu_count(),
        **{f"median_{k}": v for k, v in med.items()},
        "median_network_ms": round(med["blend_ms"] - med["features_ms"], 1),
        "blend_over_harmonic": round(med["blend_ms"] / med["harmonic_ms"], 2),
    }
    print(json.dumps(result, indent=1))
    return result


if __name__ == "__main__":
    main()
