"""``inpaintenv benchmark``: a suite of methods over a data source, with report and figures."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from ..cluster import add_scheduler_option, open_client, parse_scheduler
from ..exceptions import InvalidInputError
from ..metrics import check_coverage
from .method_options import (
    add_bad_frame_option,
    add_checkpoint_option,
    add_unfilled_option,
    check_method_names,
    checkpoint_methods,
    figure_methods,
)
from .options import (
    SYNTHETIC_HOLDOUT,
    add_common_options,
    add_source_options,
    check_source_options,
    open_source_from_args,
    test_split,
)
from ..data.inputs import INPUT_KINDS

__all__ = ["add_benchmark", "cmd_benchmark"]


def suites_epilog() -> str:
    """What each suite of :data:`~inpaintenv.benchmark.suites.SUITES` contains, for ``--help`` (generated,
    never hand-kept)."""
    import textwrap

    from ..benchmark.suites import SUITES, suite_tasks

    lines = ["suites (methods; tasks without --protocol and --input, a scan task with the methods it scores):"]
    for name, members in SUITES.items():
        tasks = "; ".join(t.label + ("" if t.methods is None else f" ({', '.join(t.methods)})")
                          for t in suite_tasks(name, members))
        lines += textwrap.wrap(
            f"{name} ({len(members)}): {', '.join(members)}; tasks: {tasks}", width=88, initial_indent="  ",
            subsequent_indent="      ", break_on_hyphens=False,
        )
    return "\n".join(lines)


def add_benchmark(subparsers: Any) -> None:
    """Declare ``inpaintenv benchmark``."""
    from ..benchmark.suites import SUITES

    p = subparsers.add_parser(
        "benchmark", help="run a suite of methods and write a report",
        description=(
            "Score a suite of methods on a drive-level test split with fixed seeds; write "
            "results.json (every per-frame metric and the environment), results.csv, "
            "results.md (mean ± 95 % bootstrap interval) and figures. Resumable: rerun the "
            "same command to continue a killed run; one run at a time per --out."
        ),
        epilog=suites_epilog(), formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--suite", choices=sorted(SUITES),
                   help="named list of methods (listed below); default: 'default' unless -m names methods")
    p.add_argument("--method", "-m", action="append", metavar="NAME",
                   help="method by name (repeatable): alone it replaces the default suite, with --suite it is "
                        "added to that suite")
    add_checkpoint_option(p)
    p.add_argument("--protocol", "-p", action="append", metavar="NAME",
                   help="occlusion protocol (repeatable; default: the suite's tasks, see below)")
    p.add_argument("--input", choices=list(INPUT_KINDS), action="append", metavar="KIND",
                   help="what a method is given under every --protocol (repeatable: every --protocol on every "
                        "--input): map (the ground truth with the hole cut), scan (each frame's single LiDAR scan with "
                        "the hole cut; densify-v1: the scan as it is), or a sparser LiDAR made from the scan: "
                        "scan-rings32-v1 / scan-rings16-v1 / scan-rings8-v1 (every 2nd / 4th / 8th laser ring) or "
                        "scan-points50-v1 / scan-points25-v1 / scan-points10-v1 (a seeded share of its points); see "
                        "docs/protocols.md. Without --protocol and --input a suite scores its tasks: rect-v1 on maps, "
                        "and for the default and classical suites densify-v1 and rect-v1 on scans with their scan "
                        "methods")
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
    p.add_argument("--interval-coverage", type=float, metavar="C",
                   help="also score the per-pixel interval of nominal coverage C (e.g. 0.9) of every method that "
                        "gives one (predict_interval or predict(return_std=True)): hole coverage, interval width, "
                        "hole RMSE of the most confident 90/80/50 %% of hole pixels, rejection AUC, the "
                        "nearest-the-border baseline, and error_rejection.png")
    add_bad_frame_option(p)
    add_unfilled_option(p)
    add_scheduler_option(p)
    add_source_options(p)
    add_common_options(p)
    p.set_defaults(func=cmd_benchmark, on_interrupt=interrupted_note)


def interrupted_note(args: argparse.Namespace) -> str:
    """What a Ctrl-C leaves behind, for the CLI's one line."""
    return f"the rows scored so far are kept in {Path(args.out) / 'rows'}; rerun the same command to resume"


def cmd_benchmark(args: argparse.Namespace) -> int:
    """Run ``inpaintenv benchmark``: check every argument, score the suite into ``--out``
    under its lock, print the tables and write the report and figures."""
    from ..files.lock import run_lock
    from ..files.ownership import check_folder
    from ..benchmark.runner import run_benchmark
    from ..benchmark.suites import LazyMethod, method_kind
    from ..conventions import check_int, check_seeds

    import time

    started = time.monotonic()
    log = (lambda msg: None) if args.quiet else (lambda msg: print(msg, file=sys.stderr))
    # Every argument is resolved and checked before any frame is scored: a typo in the
    # last option must not cost the hour spent on the first methods.
    check_source_options(args)
    methods = _methods(args)
    tasks = _tasks(args, methods)
    seeds = check_seeds(args.seed or [0], "--seed")
    check_int(args.batch_size, "--batch-size", minimum=1)
    check_int(args.figure_frames, "--figure-frames", minimum=0)
    # Checked once, here: the run takes the checked value as it is.
    coverage = None if args.interval_coverage is None else check_coverage(args.interval_coverage, "--interval-coverage")
    if args.scheduler is not None:
        parse_scheduler(args.scheduler)
    out = Path(args.out)
    check_folder(out)  # someone else's folder is refused before anything is built or written
    datasets, holdout = {}, 0.0
    for kind in dict.fromkeys(t.input_kind for t in tasks):
        datasets[kind], holdout = _dataset(argparse.Namespace(**{**vars(args), "input": kind}))

    built: dict[str, Any] = {}

    def materialise(name: str, method: Any) -> Any:
        if name not in built:
            built[name] = method() if getattr(method, "lazy", False) else method
        return built[name]

    with run_lock(out, log):
        # Methods named on the command line are built now (a checkpoint loads in a second):
        # a damaged model fails here, not after the others were scored.
        for name, method in methods.items():
            if not getattr(method, "optional", False):
                materialise(name, method)
        cached = {
            name: LazyMethod(
                lambda name=name, m=m: materialise(name, m),
                optional=getattr(m, "optional", False), identity=getattr(m, "identity", None),
                unfilled=getattr(m, "unfilled", "error"), kind=method_kind(name, m),
            )
            for name, m in methods.items()
        }
        kept = _kept_frames(datasets, args.figure_frames, seeds[0])
        with open_client(args.scheduler) as client:
            result = run_benchmark(
                cached, datasets, protocols=tasks, seeds=seeds, out_dir=out,
                resume=not args.no_resume, batch_size=args.batch_size, progress=not args.quiet, log=log,
                on_bad_frame=args.on_bad_frame, client=client, unfilled=args.unfilled,
                interval_coverage=coverage, kept=kept,
            )
        _report(args, result, out, holdout, {n: (lambda n=n: materialise(n, methods[n])) for n in methods},
                methods, datasets, tasks, seeds[0], log, started, kept)
    return 0


def _stderr(msg: str) -> None:
    print(msg, file=sys.stderr)


def _methods(args: argparse.Namespace) -> dict[str, Any]:
    """The run's methods by name, unbuilt: the ``--suite`` (``default`` when neither it nor ``-m``
    is given), then the ``-m`` names, then the ``--checkpoint`` models."""
    from ..benchmark.suites import LazyMethod, build_method, registry_kind, suite_methods
    from ..methods.registry import unfilled_policy

    overrides = {} if args.n_jobs is None else {"n_jobs": args.n_jobs}
    suite = args.suite or (None if args.method else "default")
    # An explicit --suite with -m is both: dropping the suite silently would score a run
    # without the classical methods its headline compares against.
    # Methods left out of the suite are said even with --quiet: the table would lack them silently.
    methods: dict[str, Any] = suite_methods(suite, overrides=overrides, warn=_stderr) if suite else {}
    for name in check_method_names(args.method or []):
        methods.setdefault(
            name, LazyMethod(lambda name=name: build_method(name, overrides), unfilled=unfilled_policy(name),
                             kind=registry_kind(name)))
    methods.update(checkpoint_methods(args.checkpoint, list(methods)))
    if not methods:
        raise InvalidInputError("no method to run")
    return methods


def _tasks(args: argparse.Namespace, methods: dict[str, Any]) -> list[Any]:
    """What the run scores (:mod:`~inpaintenv.benchmark.tasks`): every ``--protocol`` (default rect-v1) on
    ``--input``; with neither, the suite's tasks, whose scan tasks also score the methods added to the suite."""
    from ..benchmark.suites import SUITES, suite_tasks
    from ..benchmark.tasks import Task, check_tasks
    from ..masks import get_protocol

    if args.protocol or args.input:
        protocols = [get_protocol(p).name for p in args.protocol or ["rect-v1"]]
        if len(set(protocols)) != len(protocols):
            raise InvalidInputError(f"--protocol values must be distinct, got {protocols}")
        inputs = list(dict.fromkeys(args.input or ["map"]))
        return [task for kind in inputs for task in check_tasks(protocols, kind)]
    suite = args.suite or (None if args.method else "default")
    members = SUITES.get(suite or "", [])
    added = tuple(n for n in methods if n not in members)
    return [t if t.methods is None else Task(t.input_kind, t.protocol, t.methods + added)
            for t in suite_tasks(suite, list(methods))]


def _dataset(args: argparse.Namespace) -> tuple[Any, float]:
    """The frames scored and the share of drives held out for them (``--holdout``)."""
    from ..data.synthetic import SyntheticStreets

    dataset = open_source_from_args(args)
    holdout = args.holdout
    if holdout is None:
        holdout = SYNTHETIC_HOLDOUT if isinstance(dataset, SyntheticStreets) else 0.0
    if not 0.0 <= holdout < 1.0:
        raise InvalidInputError(f"--holdout must be in [0, 1), got {holdout}")
    if holdout > 0:
        dataset = test_split(dataset, holdout)
    return dataset, holdout


def _kept_frames(datasets: dict[str, Any], n_panels: int, seed: int) -> Any:
    """What keeps the predictions the figures draw while the run makes them (None without figures)."""
    from ..benchmark.figures import DISTANCE_FRAMES, spread_indices
    from ..benchmark.kept_frames import KeptFrames

    if n_panels <= 0:
        return None
    return KeptFrames({kind: spread_indices(ds, max(n_panels, DISTANCE_FRAMES)) for kind, ds in datasets.items()},
                      seed)


def write_task_figures(
    result: Any, tasks: list[Any], datasets: dict[str, Any], out: Path, factories: dict[str, Any],
    methods: dict[str, Any], *, n_panels: int, seed: int, log: Any, exclude: set[int], kept: Any = None,
) -> None:
    """Draw every task's figures (:func:`~inpaintenv.benchmark.figures.task_folder`): its best four
    methods by the task's RMSE on ``n_panels`` frames, its error by depth, by distance to the
    nearest measurement and by hole size."""
    from ..benchmark.figure_files import task_folder, write_figures
    from ..benchmark.report import summary_table
    from ..masks import get_protocol

    for k, task in enumerate(tasks):
        rows = [r for r in result.rows if r.get("input_kind", "map") == task.input_kind
                and r["protocol"] == task.protocol]
        if not rows:
            continue
        on_task = type(result)(rows=rows, meta=result.meta)
        metric = f"{get_protocol(task.protocol).task}_rmse"
        table = summary_table(on_task, ("method", "protocol"))
        folder = task_folder(out, task.label, first=k == 0)
        write_figures(
            on_task, factories, datasets[task.input_kind], folder,
            panel_methods=list(figure_methods(table, methods, metric=metric)), n_panels=n_panels,
            protocol=task.protocol, seed=seed, log=log, exclude=exclude,
            unfilled=result.meta.get("unfilled", {}), kept=None if kept is None else kept.lookup(task.label),
        )
        log(f"figures of {task.label} in {folder}")


def _report(
    args: argparse.Namespace, result: Any, out: Path, holdout: float, factories: dict[str, Any],
    methods: dict[str, Any], datasets: dict[str, Any], tasks: list[Any], seed: int, log: Any, started: float,
    kept: Any = None,
) -> None:
    """Write the report, print the tables (skipped frames, the learned-vs-classical
    headline), draw the figures of a finished run and write its ``report.html``."""
    import time

    from ..benchmark.density import write_density_figure
    from ..benchmark.html import write_html_report
    from ..benchmark.headline import headline_markdown, headline_title, learned_vs_classical
    from ..benchmark.report import summary_table, table_keys, to_markdown, write_report
    from ..report.results import skipped_markdown

    command = "inpaintenv " + " ".join(getattr(args, "argv", []))
    scored = time.monotonic() - started
    paths = write_report(result, out, meta={"command": command, "holdout": holdout, "seconds_scoring": scored})
    keys = table_keys(result)
    table = summary_table(result, keys)
    print(to_markdown(table, keys))
    skipped = result.meta.get("skipped_frames") or []
    if skipped:
        print("\n" + skipped_markdown(skipped))
    compared = learned_vs_classical(result)
    if compared:
        what = "hole RMSE" if all(r["task"] == "hole" for r in compared) else "RMSE of the task"
        print(f"\n{headline_title(compared)} ({what} ratio, paired 95 % CI):\n" + headline_markdown(compared))
    if args.figure_frames > 0:
        write_task_figures(result, tasks, datasets, out, factories, methods, n_panels=args.figure_frames, seed=seed,
                           log=log, exclude={r["index"] for r in skipped}, kept=kept)
        beams = write_density_figure(result, out / "figures" / "density")
        if beams is not None:
            log(f"RMSE against the LiDAR's beams: {beams}")
    log(f"wrote {paths['json']}, {paths['csv']}, {paths['markdown']}")
    write_html_report(out, log)
    total = time.monotonic() - started
    log(f"report (tables, figures, report.html): {total - scored:.1f} s, {(total - scored) / total:.0%} of this "
        f"command's {total:.1f} s")
