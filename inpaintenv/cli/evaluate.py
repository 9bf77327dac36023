"""``inpaintenv evaluate``: score methods by name on seeded (frame, occlusion) pairs and print
one Markdown table (rows kept in ``--out`` as they are scored)."""

from __future__ import annotations

import argparse
import contextlib
import sys
from pathlib import Path
from typing import Any

from ..cluster import add_scheduler_option, open_client, parse_scheduler
from ..conventions import DEFAULT_MAX_DEPTH, check_max_depth, check_seeds
from .method_options import (
    add_bad_frame_option,
    add_checkpoint_option,
    add_unfilled_option,
    check_method_names,
    parse_checkpoints,
)
from .options import (
    add_common_options,
    add_source_options,
    check_source_options,
    open_source_from_args,
)
from ..exceptions import InvalidInputError
from ..data.inputs import INPUT_KINDS

__all__ = ["add_evaluate", "cmd_evaluate"]


def _method_overrides(args: argparse.Namespace) -> dict[str, Any]:
    return {} if getattr(args, "n_jobs", None) is None else {"n_jobs": args.n_jobs}


def add_evaluate(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "evaluate", help="score methods on a data source and protocol",
        description="Score methods by name on seeded (frame, occlusion) pairs; print a Markdown table.",
    )
    p.add_argument("--method", "-m", action="append", metavar="NAME",
                   help="method name (repeatable); see `inpaintenv info` for the list")
    add_checkpoint_option(p)
    p.add_argument("--protocol", default="rect-v1", help="occlusion protocol (default rect-v1)")
    p.add_argument("--input", choices=list(INPUT_KINDS), default="map", metavar="KIND",
                   help="what a method is given: map (the ground truth with the hole cut, the default) or scan "
                        "(each frame's single LiDAR scan with the hole cut; e.g. with --protocol densify-v1)"
                        "; or a sparser LiDAR made from the scan: scan-rings32-v1 / scan-rings16-v1 / scan-rings8-v1 "
                        "(every 2nd / 4th / 8th laser ring), scan-points50-v1 / scan-points25-v1 / scan-points10-v1 "
                        "(a seeded share of its points; docs/protocols.md)")
    p.add_argument("--seed", type=int, action="append", metavar="S",
                   help="evaluation seed (repeatable; default 0)")
    p.add_argument("--batch-size", type=int, default=4, help="frames per batch (default 4)")
    p.add_argument("--max-depth", type=float, default=DEFAULT_MAX_DEPTH, help="PSNR range in metres (default 80)")
    p.add_argument("--n-jobs", type=int, help="n_jobs passed to each method")
    p.add_argument("--by-drive", action="store_true", help="also print a table per drive")
    p.add_argument("--out", metavar="DIR", help="write results.json, results.csv, table.md and table.csv here")
    p.add_argument("--interval-coverage", type=float, metavar="C",
                   help="also score the per-pixel interval of nominal coverage C (e.g. 0.9) of every method that "
                        "gives one (coverage, width, error-rejection curve; see docs/evaluate.md)")
    add_bad_frame_option(p)
    add_unfilled_option(p)
    add_scheduler_option(p)
    add_source_options(p)
    add_common_options(p)
    p.set_defaults(func=cmd_evaluate, on_interrupt=_evaluate_interrupted)


def _evaluate_interrupted(args: argparse.Namespace) -> str:
    if args.out:
        return (f"the rows scored so far are kept in {Path(args.out) / 'partial-rows.jsonl'}; evaluate does not "
                "resume, rerun the same command to score from the start (`inpaintenv benchmark` resumes)")
    return ("nothing is kept without --out; rerun the same command to score from the start "
            "(`inpaintenv benchmark` resumes)")


#: The files ``evaluate --out`` writes (``partial-rows.jsonl`` only while it scores).
OUT_FILES = ("results.json", "results.csv", "table.md", "table.csv", "partial-rows.jsonl")


def cmd_evaluate(args: argparse.Namespace) -> int:
    """Run ``inpaintenv evaluate``: check every option and build every method, then score them
    (holding the lock of ``--out``, a folder that is new, empty or written by inpaintenv)."""
    from ..files.lock import run_lock
    from ..files.ownership import check_folder
    from ..masks import get_protocol
    from ..metrics import check_coverage
    from ..methods.registry import make_method, unfilled_policy

    # Check the options and build every method first, so a typo fails before any long run.
    check_source_options(args)
    seeds = check_seeds(args.seed or [0], "--seed")
    check_max_depth(args.max_depth, "--max-depth")
    names = check_method_names(args.method or [])
    checkpoints = parse_checkpoints(args.checkpoint, names)
    if not names and not checkpoints:
        raise InvalidInputError("give at least one --method NAME or --checkpoint NAME=PATH")
    get_protocol(args.protocol)
    if args.interval_coverage is not None:  # checked once, here: evaluate takes the checked value as it is
        args.interval_coverage = check_coverage(args.interval_coverage, "--interval-coverage")
    if args.scheduler is not None:
        parse_scheduler(args.scheduler)
    out = Path(args.out) if args.out else None
    if out is not None:
        if out.exists() and not out.is_dir():
            raise InvalidInputError(f"--out {out} is a file; give a folder")
        check_folder(out)  # someone else's folder is refused before any method is built
    methods = [(name, make_method(name, **_method_overrides(args)), unfilled_policy(name)) for name in names]
    methods += [(name, make_method("checkpoint", path=path), "error") for name, path in checkpoints.items()]
    ds = open_source_from_args(args)
    with run_lock(out) if out is not None else contextlib.nullcontext():
        return _score(args, methods, ds, seeds, out)


def _score(args: argparse.Namespace, methods: list[tuple[str, Any, str]], ds: Any, seeds: list[int],
           out: Path | None) -> int:
    """Score ``methods``, print the table and, with ``--out`` (whose lock is held), write the files."""
    from ..files.ownership import adopt, claim, remove
    from ..evaluate import evaluate
    from ..report.results import EvaluationResult, skipped_markdown
    from ..benchmark.rows import append_rows
    from ..files import remove_stale_temporaries, write_text_atomic
    from ..report.tables import summary_table, table_to_csv

    on_batch = None
    if out is not None:
        # Rows land here as they are scored, so a Ctrl-C keeps them (see _evaluate_interrupted).
        # Every file is recorded as the run's before it is written; only those are replaced.
        adopt(out)
        claim(out, *OUT_FILES)
        partial = out / "partial-rows.jsonl"
        partial.unlink(missing_ok=True)  # recorded above; created by the first scored batch, never left empty
        remove_stale_temporaries(out)  # left by a writer killed mid-write

        def on_batch(rows: list[dict[str, Any]]) -> None:
            append_rows(partial, rows)  # never through a link planted there

    with open_client(args.scheduler) as client:
        results = [
            evaluate(method, ds, protocol=args.protocol, seeds=seeds, batch_size=args.batch_size,
                     max_depth=args.max_depth, progress=not args.quiet, name=name, on_batch=on_batch,
                     on_bad_frame=args.on_bad_frame, client=client, unfilled=args.unfilled or policy,
                     intervals=args.interval_coverage)
            for name, method, policy in methods
        ]
    result = EvaluationResult.concat(results)
    result.meta["command"] = "inpaintenv " + " ".join(args.argv)
    table = result.to_markdown()
    skipped = skipped_markdown(result.meta.get("skipped_frames") or [])
    if skipped:
        table += "\n\n" + skipped
    print(table)
    if args.by_drive:
        print()
        print(result.to_markdown(result.by_drive()))
    if out is not None:
        result.to_json(out / "results.json")
        result.to_csv(out / "results.csv")
        write_text_atomic(out / "table.md", table + "\n")
        table_to_csv(summary_table(result), out / "table.csv")
        remove(out, "partial-rows.jsonl")
        print(f"\nwrote {out / 'results.json'}, {out / 'results.csv'}, {out / 'table.md'}, {out / 'table.csv'}",
              file=sys.stderr)
    return 0
