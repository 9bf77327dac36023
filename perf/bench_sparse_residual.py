"""Prediction time of SparseResidualInpainter beside harmonic, on sparse scans at 16 and 8 beams.

The goal is ``predict`` <= 4x the time of ``harmonic`` measured in the same run. Both run on
the same in-memory scans (KITTI's val_selection thinned to every 4th / 8th laser ring, or
synthetic scans thinned the same way without ``--kitti-root``), one frame per call,
interleaved call by call (predict, harmonic, the features alone) so a shared machine's load
falls on all three alike. ``predict_over_harmonic`` is the median over every round of every
frame of the ratio of the round's two back-to-back calls (``cpu_``: of their process CPU time,
a worker thread's included); times are medians over the same calls. ``features_ms`` is
:func:`estimators.candidates.residual_features` alone (it includes harmonic, the floor);
``network_ms`` is the rest of ``predict``. The load average before and after is printed beside
the times: quote the ratio, not the times, on a busy machine.

Examples
--------
    python perf/bench_sparse_residual.py                                  # synthetic scans
    python perf/bench_sparse_residual.py --kitti-root <KITTI root> --repeat 7
    python perf/bench_sparse_residual.py --kitti-root <KITTI root> --name kitti-sparse-v1
    python perf/bench_sparse_residual.py --model runs/sparse/model --threads 1

The weights do not change the time, the network's size does: without ``--name`` or ``--model``
a network of the default size is fitted for one epoch on two synthetic scans.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from typing import Any, Callable

import numpy as np

from estimators.candidates import residual_features
from estimators.classical import HarmonicInpainter
from estimators.learned import SparseResidualInpainter, load, load_release
from inpaintenv.data import KittiDepth, SyntheticStreets
from inpaintenv.data.inputs import method_input

#: Densities timed: (label, the thinned-scan input kind).
DENSITIES = (("16 beams", "scan-rings16-v1"), ("8 beams", "scan-rings8-v1"))


def scans(root: str | None, kind: str, frames: int) -> list[np.ndarray]:
    """Up to ``frames`` thinned scans as a method sees them (NaN = to fill), spread over the set."""
    if root:
        ds: Any = KittiDepth(root, split="val_selection", camera="both", input=kind)
    else:
        ds = SyntheticStreets(n=frames, seed=0, input=kind)
    picks = np.unique(np.linspace(0, len(ds) - 1, frames).astype(int))
    inputs, _ = ds.load_pairs(picks)
    return [x for x in method_input(inputs, np.zeros(inputs.shape, bool), "scan") if (x > 0).any()]


def interleaved_ms(calls: dict[str, Callable[[], Any]], repeat: int) -> dict[str, list[float]]:
    """Wall-clock and CPU ms of each call over ``repeat`` rounds, one call of each per round:
    ``{name: [...], "cpu " + name: [...]}``."""
    times: dict[str, list[float]] = {k: [] for name in calls for k in (name, f"cpu {name}")}
    for _ in range(repeat):
        for name, call in calls.items():
            wall, cpu = time.perf_counter(), time.process_time()
            call()
            times[f"cpu {name}"].append(1000 * (time.process_time() - cpu))
            times[name].append(1000 * (time.perf_counter() - wall))
    return times


def main(argv: list[str] | None = None) -> dict:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--kitti-root", help="KITTI root: val_selection's scans (default: synthetic scans)")
    p.add_argument("--name", help="a shipped release of SparseResidualInpainter (e.g. kitti-sparse-v1)")
    p.add_argument("--model", help="a folder written by SparseResidualInpainter.save (default: fit a small one)")
    p.add_argument("--frames", type=int, default=5, help="frames per density (default 5)")
    p.add_argument("--repeat", type=int, default=5, help="interleaved rounds per frame; the median counts (default 5)")
    p.add_argument("--threads", type=int, help="torch threads of the network (default: the model's predict_threads)")
    args = p.parse_args(argv)
    if args.frames < 1 or args.repeat < 1 or (args.threads is not None and args.threads < 1):
        p.error("--frames, --repeat and --threads must be >= 1")

    load_before = os.getloadavg()[0]
    if args.name or args.model:
        est = load_release(args.name) if args.name else load(args.model)
    else:
        est = SparseResidualInpainter(epochs=1, pixels_per_frame=2000).fit(SyntheticStreets(n=2, seed=0, input="scan"))
    if args.threads is not None:
        est.set_params(predict_threads=args.threads)
    harmonic, fills = HarmonicInpainter(), tuple(est.fills)
    result: dict[str, Any] = {"model": args.name or args.model or "fitted on synthetic scans",
                              "width": est.width, "layers": est.layers,
                              "frames": "KITTI val_selection" if args.kitti_root else "synthetic",
                              "predict_threads": est.predict_threads, "cores": os.cpu_count(), "densities": {}}
    for label, kind in DENSITIES:
        inputs = scans(args.kitti_root, kind, args.frames)
        est.predict(inputs[0])  # warm-up (thread pools, allocator)
        rounds = [interleaved_ms({
            "predict": lambda x=x: est.predict(x),
            "harmonic": lambda x=x: harmonic.predict(x),
            "features": lambda x=x: residual_features(x, fills, np.isnan(x)),
        }, args.repeat) for x in inputs]
        times = {k: [t for r in rounds for t in r[k]] for k in rounds[0]}

        def ratio(a: str, b: str) -> float:
            # Each round's two calls ran back to back: their ratio drifts less with the load than either time.
            return round(statistics.median(x / y for x, y in zip(times[a], times[b])), 2)

        med = {f"median_{k.replace('cpu ', 'cpu_')}_ms": round(statistics.median(v), 1) for k, v in times.items()}
        result["densities"][label] = {
            "frames": len(rounds), "frame": list(inputs[0].shape), **med,
            "median_network_ms": round(med["median_predict_ms"] - med["median_features_ms"], 1),
            "predict_over_harmonic": ratio("predict", "harmonic"),
            "features_over_harmonic": ratio("features", "harmonic"),
            "cpu_predict_over_harmonic": ratio("cpu predict", "cpu harmonic"),
        }
    result["load_average"] = [round(load_before, 2), round(os.getloadavg()[0], 2)]
    print(json.dumps(result, indent=1))
    return result


if __name__ == "__main__":
    main()
