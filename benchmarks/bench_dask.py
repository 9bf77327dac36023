"""Serial run vs Dask LocalClusters of 1, 2, ... worker processes, and a full-release cost.

Usage (from the project root)::

    python benchmarks/bench_dask.py --kitti-root <KITTI root> --frames 16 --workers 1 2

Scores every method of a suite (``classical`` by default) with ``run_benchmark`` into a
fresh run folder, once in this process and once per LocalCluster size
(``inpaintenv.cluster.open_client("local:N")``: N single-threaded worker processes on
127.0.0.1), all in the same session, and checks that every configuration wrote the same
rows (all but ``ms``). One OpenCV thread and ``n_jobs=1`` everywhere, so a worker is a
core. Prints wall seconds per method and configuration, speed-up and efficiency
(``serial time / (workers x time)``; cluster start-up is shown apart, not counted), then
what scoring the full KITTI release would cost, from the serial per-frame costs measured
here. Without ``--kitti-root`` (or ``$INPAINTENV_KITTI_ROOT``) it uses SyntheticStreets.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path
from typing import Any

#: Frames of the KITTI depth-completion train split after the 352x1216 crop (docs/scaling.md).
RELEASE_FRAMES = 85_898


def release_cost(
    seconds_per_frame: dict[str, float], frames: int, protocols: int, seeds: int, workers: int, efficiency: float
) -> dict[str, float]:
    """Core-hours of scoring every (method, protocol, seed, frame), and wall hours on ``workers``.

    ``seconds_per_frame`` holds one core's seconds per scored frame of each method (the
    serial run's wall time over its frames and seeds: load, mask, method and metrics).
    Protocols are assumed to cost what the measured one did.
    """
    core_hours = frames * protocols * seeds * sum(seconds_per_frame.values()) / 3600.0
    return {"core_hours": core_hours, "wall_hours": core_hours / (workers * efficiency)}


def _one_thread(modules: tuple[str, ...] = ()) -> None:
    """One OpenCV thread; import ``modules`` now (a worker's first task must not pay for it)."""
    import importlib

    import cv2

    cv2.setNumThreads(1)
    for module in modules:
        importlib.import_module(module)


def _strip(rows: list[dict[str, Any]]) -> list[str]:
    return [json.dumps({k: v for k, v in r.items() if k != "ms"}, sort_keys=True) for r in rows]


def _run_suite(methods: dict[str, Any], dataset: Any, args: argparse.Namespace, out: Path, client: Any):
    from inpaintenv.benchmark import run_benchmark

    seconds: dict[str, float] = {}
    rows: list[dict[str, Any]] = []
    for name, method in methods.items():
        t0 = time.perf_counter()
        result = run_benchmark(
            {name: method}, dataset, protocols=[args.protocol], seeds=args.seeds, out_dir=out / name,
            resume=False, batch_size=args.batch_size, progress=False, client=client,
        )
        seconds[name] = time.perf_counter() - t0
        rows += result.rows
    return seconds, rows


def main() -> None:
    from inpaintenv.benchmark.suites import SUITES, suite_methods
    from inpaintenv.cluster import open_client
    from inpaintenv.data import open_source

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kitti-root", default=os.environ.get("INPAINTENV_KITTI_ROOT"),
                        help="KITTI root (default $INPAINTENV_KITTI_ROOT; none: SyntheticStreets)")
    parser.add_argument("--frames", type=int, default=16, help="first N frames of the train split (default 16)")
    parser.add_argument("--suite", default="classical", choices=sorted(SUITES))
    parser.add_argument("--protocol", default="rect-v1")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0])
    parser.add_argument("--batch-size", type=int, default=4)
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2], help="LocalCluster sizes (default 1 2)")
    parser.add_argument("--release-protocols", type=int, default=5, help="protocols of the full run (default 5)")
    parser.add_argument("--release-seeds", type=int, default=5, help="seeds of the full run (default 5)")
    parser.add_argument("--cluster-workers", type=int, nargs="+", default=[2, 64, 256],
                        help="cluster sizes for the full-release estimate (default 2 64 256)")
    parser.add_argument("--json", type=Path, help="also write every measurement here")
    args = parser.parse_args()

    _one_thread()
    dataset = open_source(args.kitti_root, split="train", n_frames=args.frames)
    methods = {}
    for name, lazy in suite_methods(args.suite, overrides={"n_jobs": 1}, warn=print).items():
        try:
            methods[name] = lazy()
        except (ImportError, KeyError, FileNotFoundError) as exc:
            print(f"skipping {name}: {exc}")
    n_scored = len(dataset) * len(args.seeds)
    print(f"{dataset!r}: {len(dataset)} frames x {len(args.seeds)} seeds, {args.protocol}, "
          f"{len(methods)} methods ({args.suite}), batch {args.batch_size}, cpus {os.cpu_count()}, "
          f"load average at start {os.getloadavg()[0]:.2f}")

    timings: dict[str, dict[str, float]] = {}
    startup: dict[str, float] = {}
    with tempfile.TemporaryDirectory() as tmp:
        timings["serial"], reference = _run_suite(methods, dataset, args, Path(tmp) / "serial", None)
        for n in args.workers:
            spec = f"local:{n}"
            t0 = time.perf_counter()
            with open_client(spec) as client:
                client.run(_one_thread, tuple({type(m).__module__ for m in methods.values()}))
                startup[spec] = time.perf_counter() - t0
                timings[spec], rows = _run_suite(methods, dataset, args, Path(tmp) / spec, client)
            if _strip(rows) != _strip(reference):
                raise SystemExit(f"{spec} rows differ from the serial run's")
    print(f"load average at end {os.getloadavg()[0]:.2f}; every configuration wrote the serial rows (all but ms)\n")

    serial_total = sum(timings["serial"].values())
    print("| configuration | worker processes | wall s | speed-up | efficiency | cluster start s |")
    print("|---|---:|---:|---:|---:|---:|")
    efficiency: dict[str, float] = {}
    for config, per_method in timings.items():
        workers = 1 if config == "serial" else int(config.split(":")[1])
        total = sum(per_method.values())
        efficiency[config] = serial_total / (workers * total)
        start = f"{startup[config]:.1f}" if config in startup else "–"
        print(f"| {config} | {workers if config != 'serial' else '– (this process)'} | {total:.1f} | "
              f"{serial_total / total:.2f}x | {efficiency[config]:.2f} | {start} |")

    print("\n| method | " + " | ".join(f"{c} ms/frame" for c in timings) + " |")
    print("|---|" + "---:|" * len(timings))
    for name in methods:
        print(f"| {name} | " + " | ".join(f"{1000 * timings[c][name] / n_scored:.0f}" for c in timings) + " |")

    per_frame = {name: s / n_scored for name, s in timings["serial"].items()}
    best = max((c for c in timings if c != "serial"), key=lambda c: int(c.split(":")[1]), default="serial")
    print(f"\nFull release: {RELEASE_FRAMES:,} frames x {len(methods)} methods x {args.release_protocols} "
          f"protocols x {args.release_seeds} seeds, at the serial cost of {1000 * sum(per_frame.values()):.0f} ms "
          f"per frame for the whole suite and the efficiency of {best} ({efficiency[best]:.2f}):")
    estimates = {}
    for w in args.cluster_workers:
        est = release_cost(per_frame, RELEASE_FRAMES, args.release_protocols, args.release_seeds, w, efficiency[best])
        estimates[w] = est
        print(f"  {w:>4} worker cores: {est['core_hours']:,.0f} core-hours, {est['wall_hours']:,.1f} h wall")
    if args.json:
        args.json.write_text(json.dumps({
            "dataset": repr(dataset), "frames": len(dataset), "seeds": args.seeds, "protocol": args.protocol,
            "timings_s": timings, "startup_s": startup, "efficiency": efficiency,
            "seconds_per_frame": per_frame, "release": {str(k): v for k, v in estimates.items()},
        }, indent=1))


if __name__ == "__main__":  # LocalCluster worker processes re-import this file
    main()
