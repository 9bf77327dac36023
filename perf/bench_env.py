"""Speed of the environment and of scoring at KITTI's 352x1216 crop.

Measures frames per second (best of ``--repeats`` runs, wall clock) of:

* ``plain NumPy loop``: the reference -- per frame the rect-v1 mask, the observation
  (ground truth with the hole zeroed) and hole / all-pixel RMSE on valid ground truth,
  written the direct way, on the same frames;
* ``env reset+step (in memory)``: ``gym.make("inpaintenv/DepthInpaint-v0", dataset=...)``
  on the same frames, reset then step with the observation itself as the action, so the
  number is the env's own cost (mask, checks, observation, every metric, info); its
  ratio to the plain loop is printed beside it;
* ``vector env, sync / async (2 envs)``: ``gym.make_vec`` with same-step autoreset, each
  step ending two episodes (frames/s counts both);
* ``env reset+step (KITTI PNG)``: the env reading each frame from disk (real data only);
* ``frame_metrics, batch of 8`` and ``evaluate() overhead (batch 8)``.

Frames: the first ``--frames`` frames of ``<KITTI root>/train`` (``--kitti-root`` or
``$INPAINTENV_KITTI_ROOT``), held in memory. Without that split the script falls back to
synthetic 352x1216 frames and prints so.

The "before" of a speed-up is this same script run against an older checkout in the same
session, so both figures share the machine's load::

    git worktree add <old checkout> <commit>
    PYTHONPATH=<old checkout> python perf/bench_env.py --kitti-root <KITTI root>

Usage::

    python perf/bench_env.py [--kitti-root <KITTI root>] [--episodes 200] [--profile]
"""

from __future__ import annotations

import argparse
import cProfile
import os
import platform
import pstats
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import inpaintenv
from inpaintenv.data import ArrayDataset
from inpaintenv.masks import get_protocol
from inpaintenv.metrics import frame_metrics

SHAPE = (352, 1216)
ENV_ID = "inpaintenv/DepthInpaint-v0"


def best_rate(fn: Callable[[], int], repeats: int) -> tuple[float, float]:
    """Best of ``repeats`` runs of ``fn`` (which returns frames done).

    Returns frames/s of wall-clock time and ms of this process's CPU time per frame;
    the CPU figure moves less when other jobs share the machine.
    """
    rate, cpu_ms = 0.0, float("inf")
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        n = fn()
        rate = max(rate, n / (time.perf_counter() - t0))
        cpu_ms = min(cpu_ms, 1000 * (time.process_time() - c0) / n)
    return rate, cpu_ms


def load_frames(root: str | None, n: int, shape: tuple[int, int]) -> tuple[np.ndarray, str]:
    """``n`` real KITTI train frames if ``root`` holds them, else synthetic ones; and a label."""
    if root and (Path(root) / "train").is_dir() and shape == SHAPE:
        from inpaintenv.data import KittiDepth

        kitti = KittiDepth(root, split="train")
        n = min(n, len(kitti))
        return kitti.load_batch(range(n)), f"{n} real KITTI train frames"
    from inpaintenv.data.synthetic import SyntheticStreets

    reason = "--synthetic" if root is None else f"no KITTI train split under {root}"
    frames = SyntheticStreets(n=n, seed=0, frame_shape=shape).load_batch(range(n))
    return frames, f"{n} synthetic frames ({reason}: real KITTI frames were not used)"


def plain_loop(frames: np.ndarray, episodes: int) -> Callable[[], int]:
    """The reference: rect-v1 mask, observation and hole / all RMSE, written directly."""
    protocol = get_protocol("rect-v1")

    def run() -> int:
        rng = np.random.default_rng(0)
        for _ in range(episodes):
            i = int(rng.integers(len(frames)))
            gt = frames[i]
            hole = protocol.mask(gt.shape, int(rng.integers(2**31)), i)
            obs = np.where(hole, np.float32(0.0), gt)
            valid = gt > 0
            err = (obs - gt)[valid].astype(np.float64)
            in_hole = hole[valid]
            hole_sq = err[in_hole] ** 2
            _hole_rmse = np.sqrt(hole_sq.sum() / max(hole_sq.size, 1))
            _all_rmse = np.sqrt((err**2).sum() / max(err.size, 1))
        return episodes

    return run


def env_loop(env: gym.Env, episodes: int) -> Callable[[], int]:
    """Reset, then step with the observation as the action (holes left at 0 m)."""

    def run() -> int:
        env.reset(seed=0)
        for _ in range(episodes):
            obs, _ = env.reset()
            env.step(obs["depth"])
        return episodes

    return run


def vector_loop(dataset: ArrayDataset, mode: str, steps: int, num_envs: int = 2) -> Callable[[], int]:
    """``gym.make_vec`` with same-step autoreset: every step ends ``num_envs`` episodes."""
    envs = gym.make_vec(
        ENV_ID, num_envs=num_envs, vectorization_mode=mode,
        vector_kwargs={"autoreset_mode": gym.vector.AutoresetMode.SAME_STEP}, dataset=dataset, unfilled="zero",
    )

    def run() -> int:
        obs, _ = envs.reset(seed=0)
        for _ in range(steps):
            obs, *_ = envs.step(obs["depth"])
        return steps * num_envs

    run.close = envs.close  # type: ignore[attr-defined]
    return run


def profile_env(env: gym.Env, episodes: int, top: int = 12) -> None:
    """Print the ``top`` inpaintenv functions by cumulative CPU time, in ms per episode."""
    prof = cProfile.Profile(time.process_time)  # CPU time: steadier than wall clock under load
    prof.runcall(env_loop(env, episodes))
    stats = pstats.Stats(prof).stats  # type: ignore[attr-defined]
    package = str(Path(inpaintenv.__file__).parent)
    rows = sorted(
        ((v[3], v[2], f"{Path(k[0]).name}:{k[2]}") for k, v in stats.items() if k[0].startswith(package)),
        reverse=True,
    )
    print(f"profile of {episodes} env episodes (cProfile, CPU ms per episode; cumulative / own time):")
    for cum, own, name in rows[:top]:
        print(f"  {1000 * cum / episodes:7.3f} {1000 * own / episodes:7.3f}  {name}")


def main(argv: Sequence[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kitti-root", default=os.environ.get("INPAINTENV_KITTI_ROOT"),
                        help="KITTI root (default $INPAINTENV_KITTI_ROOT); train frames are used")
    parser.add_argument("--synthetic", action="store_true", help="use synthetic frames even if KITTI is there")
    parser.add_argument("--frames", type=int, default=20, help="frames held in memory (default 20)")
    parser.add_argument("--episodes", type=int, default=200, help="episodes per timed run (default 200)")
    parser.add_argument("--repeats", type=int, default=3, help="timed runs; the best is reported (default 3)")
    parser.add_argument("--shape", type=int, nargs=2, default=SHAPE, metavar=("H", "W"),
                        help="frame size of synthetic frames (default 352 1216)")
    parser.add_argument("--profile", action="store_true", help="also profile env episodes")
    args = parser.parse_args(argv)
    if args.frames < 1 or args.episodes < 1 or args.repeats < 1:
        parser.error("--frames, --episodes and --repeats must be >= 1")
    shape = (args.shape[0], args.shape[1])
    root = None if args.synthetic else args.kitti_root

    frames, source = load_frames(root, args.frames, shape)
    memory = ArrayDataset(frames)
    results: dict[str, tuple[float, float]] = {}
    results["plain NumPy loop (reference)"] = best_rate(plain_loop(frames, args.episodes), args.repeats)
    # unfilled="zero": the loops submit the observation (holes at 0 m), as the plain loop scores it.
    env = gym.make(ENV_ID, dataset=memory, unfilled="zero")
    results["env reset+step (in memory)"] = best_rate(env_loop(env, args.episodes), args.repeats)
    for mode in ("sync", "async"):
        run = vector_loop(memory, mode, max(1, args.episodes // 2))
        try:
            results[f"vector env, {mode}, 2 envs (in memory)"] = best_rate(run, args.repeats)
        finally:
            run.close()  # type: ignore[attr-defined]
    if root is not None and source.endswith("train frames"):
        kitti_env = gym.make("inpaintenv/KittiInpaint-v0", root=root, split="train", unfilled="zero")
        n_png = max(1, min(args.episodes, 40))
        results["env reset+step (KITTI PNG)"] = best_rate(env_loop(kitti_env, n_png), args.repeats)

    batch = np.resize(frames, (8, *shape))
    holes = get_protocol("rect-v1").masks(shape, 0, range(8))
    pred = np.where(holes, np.float32(10.0), batch)
    n_batches = max(1, args.episodes // 40)

    def metrics_batch() -> int:
        for _ in range(n_batches):
            frame_metrics(pred, batch, holes)
        return 8 * n_batches

    results["frame_metrics, batch of 8"] = best_rate(metrics_batch, args.repeats)
    results["evaluate() overhead (batch 8)"] = best_rate(_evaluate_run(batch, n_batches), args.repeats)

    if args.profile:
        profile_env(gym.make(ENV_ID, dataset=memory, unfilled="zero"), args.episodes)
    plain = results["plain NumPy loop (reference)"][0]
    print(f"python {platform.python_version()}, numpy {np.__version__}, gymnasium {gym.__version__}, "
          f"{platform.machine()}, {os.cpu_count()} CPUs, frames {shape[0]}x{shape[1]}: {source}")
    print("| measurement | frames/s | ms/frame | time / plain loop | CPU ms/frame (this process) |")
    print("|---|---:|---:|---:|---:|")
    for name, (rate, cpu_ms) in results.items():
        # The async workers' CPU time is not this process's: only wall clock means something.
        cpu = "-" if "async" in name else f"{cpu_ms:.2f}"
        print(f"| {name} | {rate:.1f} | {1000 / rate:.2f} | {plain / rate:.2f} | {cpu} |")
    return {
        "source": source,
        "frames_per_s": {k: v[0] for k, v in results.items()},
        "cpu_ms_per_frame": {k: v[1] for k, v in results.items()},
    }


def _evaluate_run(batch: np.ndarray, n_batches: int) -> Callable[[], int]:
    """:func:`inpaintenv.evaluate` of a constant fill: the loop's cost around a method."""
    from inpaintenv.evaluate import evaluate

    def fill(x: np.ndarray) -> np.ndarray:
        return np.nan_to_num(x, nan=10.0)

    fill.batched = True  # type: ignore[attr-defined]
    data = ArrayDataset(np.concatenate([batch] * n_batches))
    return lambda: len(evaluate(fill, data, batch_size=8, progress=False).rows)


if __name__ == "__main__":
    main()
