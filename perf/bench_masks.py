"""Speed and hole-fraction statistics of every registered occlusion protocol.

For each protocol, at 352×1216 (the KITTI crop) unless ``--shape`` says otherwise:

* masks/s of :meth:`OcclusionProtocol.mask` on one core (best of ``--repeats`` runs of
  ``--masks`` masks each; the best run is the one least disturbed by other processes);
* the hole fraction (share of the frame masked) over ``--stats`` masks
  ``(seed 0, index 0..stats-1)``: mean, standard deviation, min, max.

Usage::

    python perf/bench_masks.py [--masks 50] [--repeats 5] [--stats 1000] [--json out.json]
"""

from __future__ import annotations

import argparse
import os
import platform
import time

# One core, as the target says; set before NumPy loads its BLAS.
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from inpaintenv.files import write_json
from inpaintenv.masks import available_protocols, get_protocol  # noqa: E402


def masks_per_second(name: str, shape: tuple[int, int], n: int, repeats: int) -> float:
    """Best-of-``repeats`` rate of drawing ``n`` consecutive masks."""
    proto = get_protocol(name)
    best = 0.0
    for r in range(repeats):
        t0 = time.perf_counter()
        for i in range(n):
            proto.mask(shape, seed=r, index=i)
        best = max(best, n / (time.perf_counter() - t0))
    return best


def hole_fractions(name: str, shape: tuple[int, int], n: int) -> dict[str, float]:
    proto = get_protocol(name)
    frac = np.array([proto.mask(shape, seed=0, index=i).mean() for i in range(n)])
    return {
        "mean": float(frac.mean()),
        "std": float(frac.std()),
        "min": float(frac.min()),
        "max": float(frac.max()),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--shape", type=int, nargs=2, default=(352, 1216), metavar=("H", "W"))
    parser.add_argument("--masks", type=int, default=50, help="masks per timed run (default 50)")
    parser.add_argument("--repeats", type=int, default=5, help="timed runs, best kept (default 5)")
    parser.add_argument("--stats", type=int, default=0, help="masks for hole-fraction statistics (0 = skip)")
    parser.add_argument("--protocols", nargs="*", default=available_protocols())
    parser.add_argument("--json", help="also write the results to this JSON file")
    args = parser.parse_args()
    shape = (int(args.shape[0]), int(args.shape[1]))

    print(f"# {platform.processor() or platform.machine()}, Python {platform.python_version()}, "
          f"NumPy {np.__version__}, shape {shape[0]}x{shape[1]}")
    header = f"{'protocol':<18} {'masks/s':>8}"
    if args.stats:
        header += f"  hole fraction over {args.stats} masks: mean ± std [min, max]"
    print(header)
    results = []
    for name in args.protocols:
        row = {"protocol": get_protocol(name).describe(), "shape": list(shape)}
        try:
            row["masks_per_s"] = masks_per_second(name, shape, args.masks, args.repeats)
        except ValueError as err:  # e.g. a frame smaller than the protocol allows
            print(f"{name:<18} skipped: {err}")
            continue
        line = f"{name:<18} {row['masks_per_s']:>8.0f}"
        if args.stats:
            s = row["hole_fraction"] = hole_fractions(name, shape, args.stats)
            line += f"  {s['mean']:.3f} ± {s['std']:.3f} [{s['min']:.3f}, {s['max']:.3f}]"
        print(line, flush=True)
        results.append(row)
    if args.json:
        write_json(args.json, results, indent=2)
        print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
