"""Throughput of every classical inpainter at KITTI size (352×1216), n_jobs=1 vs 2.

Usage::

    python perf/bench_classical.py                 # real frames if available
    python perf/bench_classical.py --frames 8 --repeats 3 --backends threading loky

Input: ground-truth frames of the real KITTI slice (``$INPAINTENV_KITTI_ROOT`` or
``<KITTI root>``) with rect-v1 holes (seed 0); without the slice, synthetic
semi-dense frames. Reports the best of ``--repeats`` runs of ``predict`` on a batch of
``--frames`` frames, as frames/s, and the speed-up of ``n_jobs=2`` over ``n_jobs=1``.
Timings depend on what else runs on the machine: run it on an idle one.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

# The methods timed are those of the accuracy table (experiments/classical_baselines.py table).
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "experiments"))
from classical_baselines import METHODS, default_root

from estimators.classical import _base
from inpaintenv.masks import get_protocol

SHAPE = (352, 1216)


def load_batch(n: int) -> tuple[np.ndarray, str]:
    """``n`` corrupted frames: real KITTI ground truth if present, else synthetic."""
    root = default_root()
    if (root / "train").is_dir():
        from inpaintenv.data.kitti import KittiDepth

        ds = KittiDepth(root, split="train")
        gt = ds.load_batch(np.linspace(0, len(ds) - 1, n).astype(int))
        source = f"KITTI {root}"
    else:
        rng = np.random.default_rng(0)
        rows = np.linspace(60.0, 4.0, SHAPE[0], dtype=np.float32)[:, None]
        gt = np.repeat((rows + np.zeros(SHAPE, np.float32))[None], n, axis=0)
        gt[rng.random(gt.shape) < 0.75] = 0.0
        source = "synthetic"
    hole = get_protocol("rect-v1").masks(SHAPE, 0, range(n))
    x = gt.copy()
    x[hole] = np.nan
    return x, source


def best_time(est, x: np.ndarray, repeats: int) -> float:
    est.predict(x[:1])  # warm-up (imports, OpenCV thread pool)
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        est.predict(x)
        times.append(time.perf_counter() - t)
    return min(times)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--frames", type=int, default=8)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--methods", nargs="+", default=list(METHODS), choices=list(METHODS))
    parser.add_argument("--backends", nargs="+", default=[_base.PARALLEL_BACKEND],
                        choices=["threading", "loky"], help="joblib backends for n_jobs=2")
    args = parser.parse_args(argv)

    x, source = load_batch(args.frames)
    print(f"{args.frames} frames {SHAPE[0]}×{SHAPE[1]} ({source}), best of {args.repeats}\n")
    head = "| method | frames/s (n_jobs=1) | ms/frame |"
    sep = "|---|---:|---:|"
    for b in args.backends:
        head += f" frames/s (n_jobs=2, {b}) | speed-up ({b}) |"
        sep += "---:|---:|"
    print(head)
    print(sep)
    default_backend = _base.PARALLEL_BACKEND
    try:
        for name in args.methods:
            est = METHODS[name]
            t1 = best_time(est.set_params(n_jobs=1), x, args.repeats)
            cells = [f"{args.frames / t1:.1f}", f"{1000 * t1 / args.frames:.0f}"]
            for backend in args.backends:
                _base.PARALLEL_BACKEND = backend
                t2 = best_time(est.set_params(n_jobs=2), x, args.repeats)
                cells += [f"{args.frames / t2:.1f}", f"{t1 / t2:.2f}×"]
            print(f"| {name} | " + " | ".join(cells) + " |", flush=True)
    finally:
        _base.PARALLEL_BACKEND = default_backend
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
