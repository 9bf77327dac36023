"""``inpaintenv benchmark``: a suite of methods over a data source, with report and figures."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["add_benchmark", "cmd_benchmark"]

#: Share of drives held out as the test split of the synthetic default source.
SYNTHETIC_HOLDOUT = 0.25


def add_benchmark(subparsers: Any, add_source_options: Callable, add_common_options: Callable) -> None:
    from .suites import SUITES

    p = subparsers.add_parser(
        "benchmark", help="run a suite of methods and write a report",
        description=(
            "Score a suite of methods on a drive-level test split with fixed seeds; write "
            "results.json (every per-frame metric and the environment), results.csv, "
            "results.md (mean ± 95 % bootstrap interval) and figures. Resumable: rerun the "
            "same command to continue a killed run."
        ),
    )
    p.add_argument("--suite", default="default", choices=sorted(SUITES),
                   help="named list of methods (default: default)")
    p.add_argument("--method", "-m", action="append", metavar="NAME",
                   help="method by name instead of a suite (repeatable)")
    p.add_argument("--checkpoint", action="append", metavar="NAME=PATH", default=[],
                   help="also score a saved neural model under NAME (repeatable)")
    p.add_argument("--protocol", action="append", metavar="NAME",
                   help="occlusion protocol (repeatable; default rect-v1)")
    p.add_argument("--seed", type=int, action="append", metavar="S", help="evaluation seed (repeatable; default 0)")
    p.add_argument("--holdout", type=float, metavar="FRACTION",
                   help=f"score only a drive-level test split holding this share of the drives "
                        f"(default {SYNTHETIC_HOLDOUT} for the synthetic source, 0 = all frames; "
                        "for KITTI choose drives with --drives/--exclude-drives)")
    p.add_argument("--n-jobs", type=int, help="n_jobs passed to every method that has it")
    p.add_argument("--batch-size", type=int, default=4, help="frames per batch (default 4)")
    p.add_argument("--out", default="benchmark-results", metavar="DIR", help="output folder (default benchmark-results)")
    p.add_argument("--no-resume", action="store_true", help="discard rows already in --out")
    p.add_argument("--figure-frames", type=int, default=2, metavar="N",
                   help="frames drawn as study-style panels, spread over the drives (default 2; 0 = no figures)")
    add_source_options(p)
    add_common_options(p)
    p.set_defaults(func=cmd_benchmark)


def _checkpoint_methods(specs: list[str]) -> dict[str, Any]:
    from ..registry import make_method
    from .identity import files_identity
    from .suites import LazyMethod

    out: dict[str, Any] = {}
    for spec in specs:
        name, sep, path = spec.partition("=")
        if not sep or not name or not path:
            raise ValueError(f"--checkpoint takes NAME=PATH, got {spec!r}")
        if not Path(path).exists():
            raise FileNotFoundError(f"checkpoint not found: {path}")
        # Hash the files now (cheap) so a resume can tell checkpoints apart unloaded.
        out[name] = LazyMethod(
            lambda path=path: make_method("checkpoint", path=path), identity=files_identity(path)
        )
    return out


def _figure_methods(table: list[dict[str, Any]], methods: dict[str, Any], k: int = 4) -> dict[str, Any]:
    """The best ``k`` methods by hole RMSE (first protocol), for readable panels."""
    first = table[0]["protocol"]
    ranked = sorted(
        (e for e in table if e["protocol"] == first and np.isfinite(e["hole_rmse"])),
        key=lambda e: e["hole_rmse"],
    )
    return {e["method"]: methods[e["method"]] for e in ranked[:k]}


def cmd_benchmark(args: argparse.Namespace) -> int:
    from ..cli import open_source_from_args
    from ..data import split_by_drive
    from ..data.synthetic import SyntheticStreets
    from .figures import write_figures
    from .headline import headline_markdown, learned_vs_classical
    from .report import summary_table, to_markdown, write_report
    from .runner import run_benchmark
    from .suites import LazyMethod, build_method, suite_methods

    log = (lambda msg: None) if args.quiet else (lambda msg: print(msg, file=sys.stderr))
    overrides = {} if args.n_jobs is None else {"n_jobs": args.n_jobs}
    if args.method:
        methods: dict[str, Any] = {
            name: LazyMethod(lambda name=name: build_method(name, overrides)) for name in args.method
        }
        for name in args.method:  # fail on a typo before any long run
            from ..registry import get_spec

            get_spec(name)
    else:
        methods = suite_methods(args.suite, overrides=overrides, warn=log)
    methods.update(_checkpoint_methods(args.checkpoint))
    if not methods:
        raise ValueError("no method to run")

    dataset = open_source_from_args(args)
    holdout = args.holdout
    if holdout is None:
        holdout = SYNTHETIC_HOLDOUT if isinstance(dataset, SyntheticStreets) else 0.0
    if not 0.0 <= holdout < 1.0:
        raise ValueError(f"--holdout must be in [0, 1), got {holdout}")
    if holdout > 0:
        dataset = split_by_drive(dataset, test_size=holdout, seed=0)[1]
    protocols = args.protocol or ["rect-v1"]
    seeds = args.seed or [0]
    log(f"benchmark: {len(methods)} methods × {len(protocols)} protocols × {len(seeds)} seeds on {dataset!r}")

    built: dict[str, Any] = {}

    def materialise(name: str, method: Any) -> Any:
        if name not in built:
            built[name] = method() if getattr(method, "lazy", False) else method
        return built[name]

    cached = {
        name: LazyMethod(
            lambda name=name, m=m: materialise(name, m),
            optional=getattr(m, "optional", False), identity=getattr(m, "identity", None),
        )
        for name, m in methods.items()
    }
    result = run_benchmark(
        cached, dataset, protocols=protocols, seeds=seeds, out_dir=args.out,
        resume=not args.no_resume, batch_size=args.batch_size, progress=not args.quiet, log=log,
    )
    command = "inpaintenv " + " ".join(getattr(args, "argv", []))
    paths = write_report(result, args.out, meta={"command": command, "holdout": holdout})
    table = summary_table(result)
    print(to_markdown(table))
    headline = headline_markdown(learned_vs_classical(result))
    if headline:
        print("\nBest learned vs strongest classical (hole RMSE ratio, paired 95 % CI):\n" + headline)
    if args.figure_frames > 0:
        fig_dir = Path(args.out) / "figures"
        write_figures(
            result, {n: (lambda n=n: materialise(n, methods[n])) for n in methods}, dataset, fig_dir,
            panel_methods=list(_figure_methods(table, methods)), n_panels=args.figure_frames,
            protocol=protocols[0], seed=seeds[0], log=log,
        )
        log(f"figures in {fig_dir}")
    log(f"wrote {paths['json']}, {paths['csv']}, {paths['markdown']}")
    return 0
