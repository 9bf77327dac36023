"""Time of one ``render_panel`` (``env.render()``'s rgb_array, ``inpaintenv show``) at KITTI's full 375x1242.

Renders ``--renders`` panels of three synthetic frames in turn (30 % of pixels with depth, a 300-px
hole, a noisy reconstruction, a two-line title that changes every call), after one warm-up render,
and prints the median and the fastest render and the first (warm-up) one, whose figure is made then.

The "before" of a speed-up is this same script run against an older checkout back to back, so both
figures share the machine's load::

    PYTHONPATH=<old checkout> python perf/bench_render.py

Usage::

    python perf/bench_render.py [--renders 20] [--shape 375 1242]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from inpaintenv.envs.render import render_panel


def frames(shape: tuple[int, int], n: int = 3) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """``n`` synthetic (ground truth, hole, reconstruction) triples of ``shape``."""
    rng = np.random.default_rng(0)
    H, W = shape
    out = []
    for k in range(n):
        gt = np.where(rng.random(shape) < 0.3, rng.uniform(2.0, 80.0, shape), 0.0).astype(np.float32)
        hole = np.zeros(shape, bool)
        hole[H // 4 + 10 * k : H // 2, W // 4 : W // 2] = True
        out.append((gt, hole, gt + rng.normal(0.0, 1.0, shape).astype(np.float32)))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--renders", type=int, default=20)
    parser.add_argument("--shape", type=int, nargs=2, default=(375, 1242), metavar=("H", "W"))
    args = parser.parse_args()
    data = frames(tuple(args.shape))
    start = time.perf_counter()
    render_panel(*data[0], title=["step 0", "warm-up"])
    first = time.perf_counter() - start
    times = []
    for i in range(args.renders):
        start = time.perf_counter()
        render_panel(*data[i % len(data)], title=[f"step {i + 1}", f"hole RMSE {0.1 * i:.2f} m"])
        times.append(time.perf_counter() - start)
    H, W = args.shape
    print(f"render_panel {H}x{W}: median {statistics.median(times) * 1000:.1f} ms, fastest {min(times) * 1000:.1f} ms "
          f"of {args.renders}; first (warm-up) {first * 1000:.1f} ms")


if __name__ == "__main__":
    main()
