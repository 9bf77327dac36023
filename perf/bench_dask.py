"""Serial run vs Dask LocalClusters of 1, 2, ... worker processes, and a full-release cost.

Usage (from the project root)::

    python perf/bench_dask.py --kitti-root <KITTI root> --frames 16 --workers 1 2
    python perf/bench_dask.py --kitti-root <KITTI root> --frames 16 --malloc-check

Scores every method of a suite (``classical`` by default) with ``run_benchmark`` into a
fresh run folder, once in this process and once per LocalCluster size
(``inpaintenv.cluster.open_client("local:N")``: N single-threaded worker processes on
127.0.0.1), all in the same session, and checks that every configuration wrote the same
rows (all but ``ms``). One OpenCV thread and ``n_jobs=1`` everywhere, so a worker is a
core. Prints wall seconds, speed-up and efficiency (``serial time / (workers x time)``;
cluster start-up shown apart, not counted), and CPU seconds of every process involved
(this one, which with a LocalCluster also runs the scheduler and nannies, and the
workers) with the CPU efficiency ``serial CPU / distributed CPU``: on a shared machine
the wall figures depend on free cores, the CPU ones show what Dask itself adds. Then
what scoring the full KITTI release would cost, from the serial CPU seconds per frame
measured here. ``--malloc-check`` instead times ``evaluate`` per frame in fresh processes with
and without the ``MALLOC_TRIM_THRESHOLD_=65536`` Dask's nanny gives its workers (which
``local:N`` unsets). Configurations run in interleaved rounds (``--repeats``) and the fastest round of
each is kept. Without ``--kitti-root`` (or ``$INPAINTENV_KITTI_ROOT``) it uses SyntheticStreets.
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


def malloc_trim_effect(kitti_root: str | None, frames: int, repeats: int = 3) -> dict[str, float]:
    """ms per frame of ``evaluate`` (``constant`` method) in a fresh process, without and
    with Dask's worker setting ``MALLOC_TRIM_THRESHOLD_=65536`` (best of ``repeats``)."""
    import subprocess
    import sys

    code = (
        "import time; from inpaintenv.data import open_source; from inpaintenv.evaluate import evaluate; "
        "from inpaintenv.methods.registry import make_method; "
        f"ds = open_source({kitti_root!r}, split='train', n_frames={frames}); m = make_method('constant'); "
        "evaluate(m, ds, n_frames=1, progress=False); best = float('inf')\n"
        f"for _ in range({repeats}):\n"
        "    t = time.perf_counter(); evaluate(m, ds, progress=False); best = min(best, time.perf_counter() - t)\n"
        "print(1000 * best / len(ds))"
    )
    out = {}
    for label, trim in (("unset", None), ("65536", "65536")):
        env = {k: v for k, v in os.environ.items() if k != "MALLOC_TRIM_THRESHOLD_"}
        if trim is not None:
            env["MALLOC_TRIM_THRESHOLD_"] = trim
        run = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
        out[label] = float(run.stdout.strip().splitlines()[-1])
    return out


def _strip(rows: list[dict[str, Any]]) -> list[str]:
    return [json.dumps({k: v for k, v in r.items() if k != "ms"}, sort_keys=True) for r in rows]


def _cpu_seconds(client: Any) -> float:
    """CPU seconds used so far by this process (with a LocalCluster: scheduler and nannies)
    and every worker process."""
    workers = client.run(time.process_time).values() if client is not None else []
    return time.process_time() + sum(workers)


def _run_suite(methods: dict[str, Any], dataset: Any, args: argparse.Namespace, out: Path, client: Any):
    """Wall and CPU seconds per method of one configuration, and the rows it wrote."""
    from inpaintenv.benchmark import run_benchmark

    wall: dict[str, float] = {}
    cpu: dict[str, float] = {}
    rows: list[dict[str, Any]] = []
    for name, method in methods.items():
        c0, t0 = _cpu_seconds(client), time.perf_counter()
        result = run_benchmark(
            {name: method}, dataset, protocols=[args.protocol], seeds=args.seeds, out_dir=out / name,
            resume=False, batch_size=args.batch_size, progress=False, client=client,
        )
        wall[name] = time.perf_counter() - t0
        cpu[name] = _cpu_seconds(client) - c0
        rows += result.rows
    return wall, cpu, rows


def parse_args() -> argparse.Namespace:
    """The command line (the suites' names are read from the package)."""
    from inpaintenv.benchmark.suites import SUITES

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
    parser.add_argument("--repeats", type=int, default=2, help="interleaved rounds, best kept (default 2)")
    parser.add_argument("--idle-seconds", type=float, default=10.0,
                        help="seconds an idle cluster is watched for its background CPU (default 10)")
    parser.add_argument("--malloc-check", action="store_true",
                        help="only time evaluate() per frame with and without Dask's MALLOC_TRIM_THRESHOLD_=65536")
    parser.add_argument("--json", type=Path, help="also write every measurement here")
    return parser.parse_args()


def suite_instances(suite: str) -> dict[str, Any]:
    """The suite's methods, one thread each; a method that cannot be built is skipped, with a line."""
    from inpaintenv.benchmark.suites import suite_methods

    methods = {}
    for name, lazy in suite_methods(suite, overrides={"n_jobs": 1}, warn=print).items():
        try:
            methods[name] = lazy()
        except (ImportError, KeyError, FileNotFoundError) as exc:
            print(f"skipping {name}: {exc}")
    return methods


def measure_configurations(methods: dict[str, Any], dataset: Any, args: argparse.Namespace) -> dict[str, dict]:
    """Wall and CPU seconds per configuration and method (best round), cluster start and idle cores.

    Raises SystemExit when a cluster's rows differ from the serial run's.
    """
    from inpaintenv.cluster import open_client

    wall: dict[str, dict[str, float]] = {}
    cpu: dict[str, dict[str, float]] = {}
    startup: dict[str, float] = {}
    idle: dict[str, float] = {}

    def keep(config: str, w: dict[str, float], c: dict[str, float]) -> None:
        # Best round per configuration: the load of a shared machine only ever adds time.
        if config not in wall or sum(w.values()) < sum(wall[config].values()):
            wall[config], cpu[config] = w, c

    with tempfile.TemporaryDirectory() as tmp:
        for round_ in range(args.repeats):  # interleaved, so a change of load hits every configuration
            w, c, reference = _run_suite(methods, dataset, args, Path(tmp) / f"serial-{round_}", None)
            keep("serial", w, c)
            for n in args.workers:
                spec = f"local:{n}"
                t0 = time.perf_counter()
                with open_client(spec) as client:
                    client.run(_one_thread, tuple({type(m).__module__ for m in methods.values()}))
                    startup[spec] = min(startup.get(spec, float("inf")), time.perf_counter() - t0)
                    w, c, rows = _run_suite(methods, dataset, args, Path(tmp) / f"{spec}-{round_}", client)
                    keep(spec, w, c)
                    # What the scheduler, nannies and workers burn doing nothing (heartbeats,
                    # event loops): part of the CPU overhead grows with the run's wall time.
                    c0, t0 = _cpu_seconds(client), time.perf_counter()
                    time.sleep(args.idle_seconds)
                    idle[spec] = (_cpu_seconds(client) - c0) / (time.perf_counter() - t0)
                if _strip(rows) != _strip(reference):
                    raise SystemExit(f"{spec} rows differ from the serial run's")
    return {"wall": wall, "cpu": cpu, "startup": startup, "idle": idle}


def print_configurations(measured: dict[str, dict], methods: dict[str, Any], n_scored: int) -> tuple[dict, dict]:
    """The table of configurations and the per-method CPU table; returns (efficiency, CPU efficiency)."""
    wall, cpu, startup, idle = measured["wall"], measured["cpu"], measured["startup"], measured["idle"]
    serial_wall, serial_cpu = sum(wall["serial"].values()), sum(cpu["serial"].values())
    print("| configuration | wall s | speed-up | efficiency | CPU s, all processes | CPU efficiency | "
          "idle cluster, cores | cluster start s |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    efficiency: dict[str, float] = {}
    cpu_efficiency: dict[str, float] = {}
    for config, per_method in wall.items():
        workers = 1 if config == "serial" else int(config.split(":")[1])
        total, total_cpu = sum(per_method.values()), sum(cpu[config].values())
        efficiency[config] = serial_wall / (workers * total)
        cpu_efficiency[config] = serial_cpu / total_cpu
        start = f"{startup[config]:.1f}" if config in startup else "–"
        background = f"{idle[config]:.3f}" if config in idle else "–"
        label = "serial (this process)" if config == "serial" else f"{config} ({workers} worker processes)"
        print(f"| {label} | {total:.1f} | {serial_wall / total:.2f}x | {efficiency[config]:.2f} | {total_cpu:.1f} | "
              f"{cpu_efficiency[config]:.2f} | {background} | {start} |")

    print("\n| method | " + " | ".join(f"{c} CPU ms/frame" for c in wall) + " |")
    print("|---|" + "---:|" * len(wall))
    for name in methods:
        print(f"| {name} | " + " | ".join(f"{1000 * cpu[c][name] / n_scored:.0f}" for c in wall) + " |")
    return efficiency, cpu_efficiency


def print_release_estimates(per_frame: dict[str, float], configs: list[str], cpu_efficiency: dict[str, float],
                            n_methods: int, args: argparse.Namespace) -> dict[int, dict]:
    """The full release's cost on each ``--cluster-workers`` size, ideal and at the largest cluster's efficiency."""
    best = max((c for c in configs if c != "serial"), key=lambda c: int(c.split(":")[1]), default="serial")
    print(f"\nFull release: {RELEASE_FRAMES:,} frames x {n_methods} methods x {args.release_protocols} "
          f"protocols x {args.release_seeds} seeds at {1000 * sum(per_frame.values()):.0f} CPU ms per frame for the "
          f"whole suite; wall time with every worker on a core of its own, ideal and at the CPU efficiency of "
          f"{best} ({cpu_efficiency[best]:.2f}):")
    estimates = {}
    for w in args.cluster_workers:
        ideal = release_cost(per_frame, RELEASE_FRAMES, args.release_protocols, args.release_seeds, w, 1.0)
        measured = release_cost(per_frame, RELEASE_FRAMES, args.release_protocols, args.release_seeds, w,
                                cpu_efficiency[best])
        estimates[w] = {"ideal": ideal, "measured_efficiency": measured}
        print(f"  {w:>4} worker cores: {ideal['core_hours']:,.0f} core-hours of scoring, "
              f"{ideal['wall_hours']:,.1f}-{measured['wall_hours']:,.1f} h wall")
    return estimates


def main() -> None:
    from inpaintenv.data import open_source
    from inpaintenv.files import write_json

    args = parse_args()
    if args.malloc_check:
        ms = malloc_trim_effect(args.kitti_root, args.frames)
        print(f"evaluate(constant), {args.frames} frames, ms/frame: MALLOC_TRIM_THRESHOLD_ unset {ms['unset']:.1f}, "
              f"=65536 (Dask's worker default) {ms['65536']:.1f}: {ms['65536'] / ms['unset']:.2f}x")
        return
    _one_thread()
    dataset = open_source(args.kitti_root, split="train", n_frames=args.frames)
    methods = suite_instances(args.suite)
    n_scored = len(dataset) * len(args.seeds)
    print(f"{dataset!r}: {len(dataset)} frames x {len(args.seeds)} seeds, {args.protocol}, "
          f"{len(methods)} methods ({args.suite}), batch {args.batch_size}, cpus {os.cpu_count()}, "
          f"load average at start {os.getloadavg()[0]:.2f}")
    measured = measure_configurations(methods, dataset, args)
    print(f"load average at end {os.getloadavg()[0]:.2f}; every configuration wrote the serial rows (all but ms)\n")
    efficiency, cpu_efficiency = print_configurations(measured, methods, n_scored)

    # One core's seconds per scored frame, from the serial run's CPU time (steadier than
    # wall time on a shared machine); a worker with a core of its own wastes what its
    # configuration's CPU efficiency says.
    per_frame = {name: s / n_scored for name, s in measured["cpu"]["serial"].items()}
    estimates = print_release_estimates(per_frame, list(measured["wall"]), cpu_efficiency, len(methods), args)
    if args.json:
        write_json(args.json, {
            "dataset": repr(dataset), "frames": len(dataset), "seeds": args.seeds, "protocol": args.protocol,
            "wall_s": measured["wall"], "cpu_s": measured["cpu"], "startup_s": measured["startup"],
            "efficiency": efficiency, "cpu_efficiency": cpu_efficiency, "idle_cores": measured["idle"],
            "seconds_per_frame": per_frame, "release": {str(k): v for k, v in estimates.items()},
        })


if __name__ == "__main__":  # LocalCluster worker processes re-import this file
    main()
