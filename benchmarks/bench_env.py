"""Speed of the environment and of scoring at KITTI's 352x1216 crop.

Measures frames per second of:

* ``env reset+step (in memory)``: :class:`DepthInpaintEnv` on frames already in memory,
  so the number is the env's own cost (mask drawing, observation, metrics);
* ``env reset+step (KITTI PNG)``: the same reading each frame from the KITTI slice
  (only with ``--kitti-root``);
* ``frame_metrics, batch of 8``: :func:`inpaintenv.metrics.frame_metrics` on an
  ``(8, 352, 1216)`` batch;
* ``evaluate() overhead``: :func:`inpaintenv.evaluate` with a method that returns a
  constant fill (data in memory), i.e. the loop's cost around any real method.

Usage::

    python benchmarks/bench_env.py [--kitti-root ../shared/kitti] [--frames 40]
"""

from __future__ import annotations

import argparse
import platform
import time
from collections.abc import Callable

import numpy as np

from inpaintenv.data import ArrayDataset
from inpaintenv.envs import DepthInpaintEnv
from inpaintenv.evaluate import evaluate
from inpaintenv.metrics import frame_metrics

SHAPE = (352, 1216)


def best_rate(fn: Callable[[], int], repeats: int) -> float:
    """Frames/s of the fastest of ``repeats`` runs of ``fn`` (which returns frames done)."""
    best = 0.0
    for _ in range(repeats):
        t0 = time.perf_counter()
        n = fn()
        best = max(best, n / (time.perf_counter() - t0))
    return best


def env_loop(env: DepthInpaintEnv, n: int) -> Callable[[], int]:
    def run() -> int:
        env.reset(seed=0)
        for _ in range(n):
            obs, _ = env.reset()
            env.step(obs["depth"])  # holes left at 0 m: a valid (bad) reconstruction
        return n

    return run


def profile_env(env: DepthInpaintEnv, n: int) -> None:
    """Print how much of ``n`` env episodes is spent in ``frame_metrics``."""
    import cProfile
    import pstats

    prof = cProfile.Profile()
    prof.runcall(env_loop(env, n))
    stats = pstats.Stats(prof)
    total = stats.total_tt  # type: ignore[attr-defined]
    in_metrics = sum(v[3] for k, v in stats.stats.items() if k[2] == "frame_metrics")  # type: ignore[attr-defined]
    print(
        f"profile of {n} episodes: {total:.2f} s total, {in_metrics:.2f} s in frame_metrics, "
        f"{1000 * (total - in_metrics) / n:.1f} ms per episode elsewhere (profiler overhead included)"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kitti-root", help="KITTI slice for the PNG-reading env measurement")
    parser.add_argument("--frames", type=int, default=40, help="episodes per run (default 40)")
    parser.add_argument("--repeats", type=int, default=3, help="runs; the best is reported (default 3)")
    parser.add_argument("--profile", action="store_true", help="also profile env episodes: time in frame_metrics")
    args = parser.parse_args()

    from inpaintenv.data.synthetic import SyntheticStreets

    frames = SyntheticStreets(n=8, seed=0, frame_shape=SHAPE).load_batch(range(8))
    memory = ArrayDataset(frames)
    results: list[tuple[str, float]] = []

    results.append(("env reset+step (in memory)", best_rate(env_loop(DepthInpaintEnv(memory), args.frames), args.repeats)))
    if args.kitti_root:
        from inpaintenv.data.kitti import KittiDepth

        kitti = KittiDepth(args.kitti_root, split="train")
        results.append(("env reset+step (KITTI PNG)", best_rate(env_loop(DepthInpaintEnv(kitti), args.frames), args.repeats)))

    from inpaintenv.masks import get_protocol

    holes = get_protocol("rect-v1").masks(SHAPE, 0, range(8))
    pred = np.where(holes, 10.0, frames).astype(np.float32)

    def metrics_batch() -> int:
        for _ in range(max(1, args.frames // 8)):
            frame_metrics(pred, frames, holes)
        return 8 * max(1, args.frames // 8)

    results.append(("frame_metrics, batch of 8", best_rate(metrics_batch, args.repeats)))

    def fill(x: np.ndarray) -> np.ndarray:
        return np.nan_to_num(x, nan=10.0)

    fill.batched = True  # type: ignore[attr-defined]
    n_eval = max(8, args.frames)
    big = ArrayDataset(np.concatenate([frames] * (n_eval // 8)))
    results.append((
        "evaluate() overhead (batch 8)",
        best_rate(lambda: len(evaluate(fill, big, batch_size=8, progress=False).rows), args.repeats),
    ))

    if args.profile:
        profile_env(DepthInpaintEnv(memory), args.frames)
    print(f"python {platform.python_version()}, numpy {np.__version__}, {platform.machine()}, frames {SHAPE[0]}x{SHAPE[1]}")
    print("| measurement | frames/s |")
    print("|---|---:|")
    for name, rate in results:
        print(f"| {name} | {rate:.1f} |")


if __name__ == "__main__":
    main()
