"""The ``inpaintenv`` command line: ``info``, ``evaluate``, ``show``.

Each subcommand lives in two small functions: ``add_<name>(subparsers)`` declares its
options and ``cmd_<name>(args)`` runs it. More subcommands (``benchmark``, ``train``)
are added by appending their ``add_`` function to :data:`SUBCOMMANDS`; the shared
data-source options come from :mod:`inpaintenv.cli_options` (re-exported here).

Examples
--------
::

    inpaintenv info
    inpaintenv evaluate --method telea --method telea-hole --n-frames 8 --out results/
    inpaintenv show --method ipbasic --index 3 --out panel.png
    inpaintenv info --kitti-root <KITTI root> --split train
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .cli_options import (
    add_common_options,
    add_source_options,
    check_source_options,
    open_source_from_args,
)
from .cli_train import add_train
from .cluster import ClusterError, add_scheduler_option, open_client, parse_scheduler
from .conventions import DEFAULT_MAX_DEPTH, check_max_depth, check_seed, check_seeds
from .data.base import as_dataset
from .method_options import (
    add_bad_frame_option,
    add_checkpoint_option,
    add_unfilled_option,
    check_method_names,
    parse_checkpoints,
)

__all__ = ["SUBCOMMANDS", "add_source_options", "build_parser", "main", "open_source_from_args"]

#: Exit status after Ctrl-C (128 + SIGINT, as shells report it).
INTERRUPTED = 130

#: Errors reported as one line ("inpaintenv: error: ...") with exit status 1, not a traceback.
USER_ERRORS: tuple[type[BaseException], ...] = (
    ValueError, KeyError, TypeError, FileNotFoundError, ImportError, IndexError, OSError, ClusterError,
)


def _method_overrides(args: argparse.Namespace) -> dict[str, Any]:
    return {} if getattr(args, "n_jobs", None) is None else {"n_jobs": args.n_jobs}


# ---------------------------------------------------------------------------------------
# info
# ---------------------------------------------------------------------------------------
def add_info(subparsers: Any) -> None:
    p = subparsers.add_parser("info", help="summarise a data source", description="Summarise a data source: frames, drives, sizes, valid-pixel density.")
    add_source_options(p)
    add_common_options(p)
    p.add_argument("--sample", type=int, default=8, help="frames decoded to measure density (default 8)")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.set_defaults(func=cmd_info)


def describe_source(ds: Any, n_sample: int = 8) -> dict[str, Any]:
    """``ds.summary()`` for ``inpaintenv info``, with ``--sample`` checked first."""
    if n_sample < 1:
        raise ValueError(f"--sample must be >= 1, got {n_sample}")
    return dict(as_dataset(ds).summary(n_sample=n_sample))


def cmd_info(args: argparse.Namespace) -> int:
    from .masks import available_protocols
    from .registry import available_aliases, available_methods

    ds = open_source_from_args(args)
    info = describe_source(ds, args.sample)
    info["frames_used"] = len(ds)
    if args.json:
        info["methods"] = available_methods()
        info["aliases"] = available_aliases()
        print(json.dumps(info, indent=1))
        return 0
    for key, value in info.items():
        if key == "valid_density" and value is not None:
            value = f"{100 * value:.1f} % of pixels (mean over {info.get('sampled_frames', '?')} frames)"
        elif isinstance(value, dict):
            value = ", ".join(f"{k}: {v}" for k, v in value.items())
        print(f"{key:>16}: {value}")
    print(f"{'protocols':>16}: {', '.join(available_protocols())}")
    print(f"{'methods':>16}: {', '.join(available_methods())}")
    print(f"{'aliases':>16}: {', '.join(f'{a} -> {t}' for a, t in available_aliases().items())}")
    return 0


# ---------------------------------------------------------------------------------------
# evaluate
# ---------------------------------------------------------------------------------------
def add_evaluate(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "evaluate", help="score methods on a data source and protocol",
        description="Score methods by name on seeded (frame, occlusion) pairs; print a Markdown table.",
    )
    p.add_argument("--method", "-m", action="append", metavar="NAME",
                   help="method name (repeatable); see `inpaintenv info` for the list")
    add_checkpoint_option(p)
    p.add_argument("--protocol", default="rect-v1", help="occlusion protocol (default rect-v1)")
    p.add_argument("--seed", type=int, action="append", metavar="S",
                   help="evaluation seed (repeatable; default 0)")
    p.add_argument("--batch-size", type=int, default=4, help="frames per batch (default 4)")
    p.add_argument("--max-depth", type=float, default=DEFAULT_MAX_DEPTH, help="PSNR range in metres (default 80)")
    p.add_argument("--n-jobs", type=int, help="n_jobs passed to each method")
    p.add_argument("--by-drive", action="store_true", help="also print a table per drive")
    p.add_argument("--out", metavar="DIR", help="write results.json, results.csv, table.md and table.csv here")
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


def cmd_evaluate(args: argparse.Namespace) -> int:
    from .evaluate import EvaluationResult, evaluate, skipped_markdown
    from .masks import get_protocol
    from .registry import make_method, unfilled_policy
    from .tables import summary_table, table_to_csv

    # Check the options and build every method first, so a typo fails before any long run.
    check_source_options(args)
    seeds = check_seeds(args.seed or [0], "--seed")
    check_max_depth(args.max_depth, "--max-depth")
    names = check_method_names(args.method or [])
    checkpoints = parse_checkpoints(args.checkpoint, names)
    if not names and not checkpoints:
        raise ValueError("give at least one --method NAME or --checkpoint NAME=PATH")
    get_protocol(args.protocol)
    if args.scheduler is not None:
        parse_scheduler(args.scheduler)
    out = Path(args.out) if args.out else None
    if out is not None and out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} is a file; give a folder")
    methods = [(name, make_method(name, **_method_overrides(args)), unfilled_policy(name)) for name in names]
    methods += [(name, make_method("checkpoint", path=path), "error") for name, path in checkpoints.items()]
    ds = open_source_from_args(args)
    on_batch = None
    if out is not None:
        # Rows land here as they are scored, so a Ctrl-C keeps them (see _evaluate_interrupted).
        out.mkdir(parents=True, exist_ok=True)
        partial = out / "partial-rows.jsonl"
        partial.unlink(missing_ok=True)  # created by the first scored batch, never left empty

        def on_batch(rows: list[dict[str, Any]]) -> None:
            with partial.open("a") as f:
                f.writelines(json.dumps(row) + "\n" for row in rows)

    with open_client(args.scheduler) as client:
        results = [
            evaluate(method, ds, protocol=args.protocol, seeds=seeds, batch_size=args.batch_size,
                     max_depth=args.max_depth, progress=not args.quiet, name=name, on_batch=on_batch,
                     on_bad_frame=args.on_bad_frame, client=client, unfilled=args.unfilled or policy)
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
        (out / "table.md").write_text(table + "\n")
        table_to_csv(summary_table(result), out / "table.csv")
        (out / "partial-rows.jsonl").unlink(missing_ok=True)
        print(f"\nwrote {out / 'results.json'}, {out / 'results.csv'}, {out / 'table.md'}, {out / 'table.csv'}",
              file=sys.stderr)
    return 0


# ---------------------------------------------------------------------------------------
# show
# ---------------------------------------------------------------------------------------
def add_show(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "show", help="save a PNG panel of one frame",
        description="Save the panel input | hole | ground truth | reconstruction | error of one frame.",
    )
    p.add_argument("--method", "-m", metavar="NAME", help="method to run (default: none, data only)")
    p.add_argument("--index", type=int, default=0, help="frame index in the source (default 0)")
    p.add_argument("--seed", type=int, default=0, help="evaluation seed of the mask (default 0)")
    p.add_argument("--protocol", default="rect-v1", help="occlusion protocol (default rect-v1)")
    p.add_argument("--max-depth", type=float, default=DEFAULT_MAX_DEPTH, help="colour scale top in metres")
    p.add_argument("--out", default="panel.png", help="PNG to write (default panel.png)")
    add_unfilled_option(p)
    add_source_options(p)
    add_common_options(p)
    p.set_defaults(func=cmd_show)


def _fmt(v: float, unit: str, digits: int = 3) -> str:
    return "n/a" if v is None or np.isnan(v) else f"{v:.{digits}f}{unit}"


def cmd_show(args: argparse.Namespace) -> int:
    import cv2

    from .conventions import corrupt
    from .envs.render import render_panel
    from .evaluate import run_method
    from .masks import get_protocol
    from .metrics import frame_metrics, interpolate_background
    from .registry import make_method, unfilled_policy

    out = Path(args.out)
    # OpenCV picks the format from the suffix and fails with its own traceback otherwise.
    if out.suffix.lower() != ".png" or out.is_dir():
        raise ValueError(f"--out must be a .png file, got {args.out!r}")
    check_max_depth(args.max_depth, "--max-depth")
    check_seed(args.seed, "--seed")
    check_source_options(args)
    method = make_method(args.method) if args.method else None
    ds = open_source_from_args(args)
    if not 0 <= args.index < len(ds):
        raise IndexError(f"--index {args.index} is out of range for a source of {len(ds)} frames")
    proto = get_protocol(args.protocol)
    gt = ds[args.index]
    # The same mask evaluate() uses for (protocol, seed, index).
    hole = proto.mask(gt.shape, args.seed, args.index)
    lines = [f"{ds.frame_ids[args.index]}  {proto.name} seed {args.seed}  hole {100 * hole.mean():.1f} %"]
    pred = None
    if method is not None:
        batch, ms = run_method(method, corrupt(gt, hole)[None], args.method)
        policy = args.unfilled or unfilled_policy(args.method)
        # Shown as scored: after the devkit's interpolation when that is the policy.
        pred = interpolate_background(batch[0]) if policy == "interpolate" else batch[0]
        m = {k: float(v) for k, v in frame_metrics(pred, gt, hole, max_depth=args.max_depth, unfilled=policy).items()}
        lines.append(
            f"{args.method}: hole RMSE {_fmt(m['hole_rmse'], ' m')} MAE {_fmt(m['hole_mae'], ' m')} "
            f"PSNR {_fmt(m['hole_psnr'], ' dB', 2)} | all RMSE {_fmt(m['all_rmse'], ' m')} "
            f"PSNR {_fmt(m['all_psnr'], ' dB', 2)} | {ms:.0f} ms"
        )
    panel = render_panel(gt, hole, pred, max_depth=args.max_depth, title=lines)
    out.parent.mkdir(parents=True, exist_ok=True)
    if not cv2.imwrite(str(out), cv2.cvtColor(panel, cv2.COLOR_RGB2BGR)):
        raise OSError(f"could not write {out} (use a .png name)")
    for line in lines:
        print(line)
    print(f"wrote {out} ({panel.shape[1]}x{panel.shape[0]})", file=sys.stderr)
    return 0


# ---------------------------------------------------------------------------------------
# entry point
# ---------------------------------------------------------------------------------------
#: ``add_<name>(subparsers)`` functions, one per subcommand.
def add_benchmark(subparsers: Any) -> None:
    from .benchmark.command import add_benchmark as add

    add(subparsers, add_source_options, add_common_options)


def add_export(subparsers: Any) -> None:
    from .submission.command import add_export as add

    add(subparsers, add_source_options, add_common_options)


def add_score(subparsers: Any) -> None:
    from .submission.command import add_score as add

    add(subparsers, add_common_options)


SUBCOMMANDS: list[Callable[[Any], None]] = [
    add_info, add_evaluate, add_show, add_benchmark, add_train, add_export, add_score,
]


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every subcommand of :data:`SUBCOMMANDS`."""
    from ._version import __version__

    parser = argparse.ArgumentParser(
        prog="inpaintenv",
        description="Benchmark for depth-only inpainting of large occlusions in outdoor LiDAR depth.",
    )
    parser.add_argument("--version", action="version", version=f"inpaintenv {__version__}")
    subparsers = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for add in SUBCOMMANDS:
        add(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the exit status (0 = success, 1 = error in the inputs,
    130 = interrupted by Ctrl-C).

    Errors in the inputs, and Ctrl-C, print one line to stderr (for Ctrl-C: what was kept
    and how to resume); set ``INPAINTENV_TRACEBACK=1`` to get the traceback instead.

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments without the program name; ``sys.argv[1:]`` by default.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    args = build_parser().parse_args(argv)
    args.argv = argv
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        # Ctrl-C: one line saying what is kept and how to continue, not a traceback from
        # wherever the signal landed (often deep inside torch).
        if os.environ.get("INPAINTENV_TRACEBACK"):
            raise
        note = args.on_interrupt(args) if getattr(args, "on_interrupt", None) else "nothing was written"
        print(f"inpaintenv {args.command}: interrupted; {note}", file=sys.stderr)
        return INTERRUPTED
    except USER_ERRORS as exc:
        if os.environ.get("INPAINTENV_TRACEBACK"):
            raise
        msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        print(f"inpaintenv {args.command}: error: {msg}", file=sys.stderr)
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
