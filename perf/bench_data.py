"""Frames per second of the data layer: KITTI PNG read+crop and SyntheticStreets generation.

Usage (from the project root)::

    python perf/bench_data.py [--kitti-root <KITTI root>] [--n-kitti 40] [--n-synthetic 16]

Prints one row per source: frames, wall seconds, CPU seconds, frames/s (wall) and
milliseconds per frame (CPU time of this process, which is less disturbed by other
jobs on a shared machine). Single process, single thread of NumPy work.
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from pathlib import Path

import numpy as np

from inpaintenv.data import KittiDepth, SyntheticStreets

ROOT = Path(__file__).resolve().parents[1]


def _time(load, indices) -> tuple[float, float]:
    """Wall and CPU seconds to load the given frames once."""
    w0, c0 = time.perf_counter(), time.process_time()
    for i in indices:
        load(int(i))
    return time.perf_counter() - w0, time.process_time() - c0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    default = os.environ.get("INPAINTENV_KITTI_ROOT")
    parser.add_argument(
        "--kitti-root", default=default, help="KITTI root (default: $INPAINTENV_KITTI_ROOT)"
    )
    parser.add_argument("--n-kitti", type=int, default=40, help="KITTI frames to read")
    parser.add_argument("--n-synthetic", type=int, default=16, help="synthetic frames to generate per kind")
    args = parser.parse_args()

    rows = []
    if args.kitti_root and Path(args.kitti_root).is_dir():
        for kind in ("groundtruth", "velodyne_raw"):
            ds = KittiDepth(args.kitti_root, split="train", kind=kind)
            idx = np.arange(min(args.n_kitti, len(ds)))
            ds[0]  # warm the file cache and OpenCV
            rows.append((f"KittiDepth {kind} read+crop 1242x375->1216x352", len(idx), *_time(ds.__getitem__, idx)))
    else:
        print(f"(no KITTI at {args.kitti_root}: skipping the read benchmark)")
    for kind in ("dense", "velodyne_raw", "groundtruth"):
        SyntheticStreets(n=1, seed=0, kind=kind)[0]  # warm-up (imports, lookup tables)
        # A seed not seen before: building each drive's street is part of the cost.
        fresh = SyntheticStreets(n=args.n_synthetic, seed=1, kind=kind)
        rows.append((f"SyntheticStreets {kind} 1216x352", len(fresh), *_time(fresh.__getitem__, range(len(fresh)))))

    print(f"python {platform.python_version()}, numpy {np.__version__}, {platform.machine()}, "
          f"{os.cpu_count()} CPUs visible, load average {os.getloadavg()[0]:.2f}")
    print(f"{'source':<52} {'frames':>6} {'wall s':>7} {'cpu s':>7} {'frames/s':>9} {'cpu ms/frame':>13}")
    for name, n, wall, cpu in rows:
        print(f"{name:<52} {n:>6} {wall:>7.2f} {cpu:>7.2f} {n / wall:>9.1f} {1e3 * cpu / n:>13.1f}")


if __name__ == "__main__":
    main()
