"""Time of ``evaluate()`` on the built-in data, and the share spent outside the method.

Usage (from the project root)::

    python perf/bench_evaluate.py                       # 16 frames, 3 repeats
    python perf/bench_evaluate.py --frames 32 --repeats 5 --json out.json

Two measurements, each the best of ``--repeats`` runs (the least disturbed by other jobs
on a shared machine), wall and CPU time of this process:

* ``built-in data``: ``evaluate(method, SyntheticStreets(n=FRAMES), "rect-v1", seeds=[0, 1])``,
  frames generated once before timing (``SyntheticStreets`` caches nothing, so the
  frames are generated again on every load: that is part of the figure, as in a run);
* ``in-memory frames``: the same frames as one ``(N, H, W)`` array, so what remains is
  ``evaluate()``'s own work -- loading and checking the frames, masks, the method
  input, checking the output, the metrics, the rows.

The method is a cheap batched fill (NaN -> 10 m) so that ``evaluate()`` itself, not a
method, is what is measured. Single process; frames at KITTI's 352x1216 crop.
"""

from __future__ import annotations

import argparse
import platform
import subprocess
import time
from pathlib import Path

import numpy as np

from inpaintenv.data import SyntheticStreets
from inpaintenv.evaluate import evaluate
from inpaintenv.files import write_json

ROOT = Path(__file__).resolve().parents[1]


def fill(x: np.ndarray) -> np.ndarray:
    """A batched method costing next to nothing: every pixel to fill becomes 10 m."""
    return np.where(np.isnan(x), np.float32(10.0), x)


fill.batched = True  # type: ignore[attr-defined]


def best_of(repeats: int, run) -> tuple[float, float]:
    """Best wall and best CPU seconds of ``repeats`` calls of ``run``."""
    walls, cpus = [], []
    for _ in range(repeats):
        w0, c0 = time.perf_counter(), time.process_time()
        run()
        walls.append(time.perf_counter() - w0)
        cpus.append(time.process_time() - c0)
    return min(walls), min(cpus)


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=16, help="frames of the built-in data (default 16)")
    parser.add_argument("--repeats", type=int, default=3, help="runs per measurement; the best is kept (default 3)")
    parser.add_argument("--json", metavar="PATH", help="also write the numbers here")
    args = parser.parse_args(argv)
    if args.frames < 1 or args.repeats < 1:
        parser.error("--frames and --repeats must be >= 1")

    data = SyntheticStreets(n=args.frames, seed=0)
    frames = np.stack([data[i] for i in range(len(data))])
    kw = {"protocol": "rect-v1", "seeds": [0, 1], "progress": False, "batch_size": 4}
    evaluate(fill, frames[:4], **kw)  # warm-up: imports, tqdm, first allocations
    n = 2 * args.frames  # (frame, seed) pairs scored per run

    builtin = best_of(args.repeats, lambda: evaluate(fill, data, **kw))
    memory = best_of(args.repeats, lambda: evaluate(fill, frames, **kw))
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True,
                                text=True, check=False).stdout.strip() or None
    except OSError:
        commit = None
    out = {
        "commit": commit, "frames": args.frames, "pairs": n, "repeats": args.repeats,
        "frame_shape": list(frames.shape[1:]),
        "builtin_ms_per_pair": {"wall": round(1000 * builtin[0] / n, 2), "cpu": round(1000 * builtin[1] / n, 2)},
        "in_memory_ms_per_pair": {"wall": round(1000 * memory[0] / n, 2), "cpu": round(1000 * memory[1] / n, 2)},
        "python": platform.python_version(), "numpy": np.__version__,
    }
    print(f"evaluate() on {args.frames} frames x 2 seeds at {frames.shape[1]}x{frames.shape[2]}, best of "
          f"{args.repeats} (commit {commit}):")
    for label, (wall, cpu) in (("built-in data", builtin), ("in-memory frames", memory)):
        print(f"  {label:17s} {1000 * wall / n:7.2f} ms/pair wall  {1000 * cpu / n:7.2f} ms/pair CPU")
    if args.json:
        write_json(args.json, out)
    return out


if __name__ == "__main__":
    main()
