"""``inpaintenv score``: the benchmark for methods that run anywhere.

``inpaintenv export`` writes the occluded inputs of a data source and protocol as files;
any program writes one prediction per input; ``score`` checks and scores them and writes
the run folder and report of ``inpaintenv benchmark``, with the classical methods given
by ``-m`` scored on the same frames and masks in the same table.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from .method_options import (
    add_checkpoint_option,
    check_method_names,
    checkpoint_methods,
    figure_methods,
)
from .options import add_common_options
from ..exceptions import InvalidInputError

__all__ = ["add_score", "cmd_score"]


def add_score(subparsers: Any) -> None:
    """Declare ``inpaintenv score`` (no data-source options: the manifest names the data)."""
    from ..submission.predictions import ON_MISSING

    p = subparsers.add_parser(
        "score", help="score a folder of predictions for an export",
        description=(
            "Check a folder of predictions against an export's manifest and its ground truth, score them with the "
            "metrics of `evaluate`, and write the run folder and report of `inpaintenv benchmark` (results.json, "
            ".csv, .md, figures). Methods given by -m are scored on the same frames and masks in the same table. "
            "Interval files beside the predictions (<name>_low.png and <name>_high.png, or <name>_std.png) add "
            "coverage, width and the error-rejection curve (see --interval-coverage). "
            "Resumable: rerun the same command to continue."
        ),
    )
    p.add_argument("--manifest", required=True, metavar="KEY",
                   help="the score key `inpaintenv export` wrote (<export>.key.json beside the export folder)")
    p.add_argument("--predictions", required=True, metavar="DIR",
                   help="folder holding each prediction at its input's relative path (16-bit PNG, metres × 256)")
    p.add_argument("--name", required=True, help="method name of the predictions in the report")
    p.add_argument("--kitti-root", metavar="PATH",
                   help="KITTI root holding the ground truth of a KITTI export (default $INPAINTENV_KITTI_ROOT)")
    p.add_argument("--method", "-m", action="append", metavar="NAME",
                   help="also score this method by name on the same frames (repeatable), e.g. -m harmonic")
    add_checkpoint_option(p)
    p.add_argument("--on-missing", choices=ON_MISSING, default="error",
                   help="a missing prediction, or a PNG the manifest does not list, stops the scoring (error, the "
                        "default) or is left out and listed in results.json (skip)")
    p.add_argument("--allow-unfilled", action="store_true",
                   help="accept predictions with 0 at hole pixels (scored as 0 m) instead of refusing them")
    p.add_argument("--out", default="score-results", metavar="DIR", help="run folder (default score-results)")
    p.add_argument("--no-resume", action="store_true", help="discard rows already in --out")
    p.add_argument("--batch-size", type=int, default=4, help="frames per batch (default 4)")
    p.add_argument("--figure-frames", type=int, default=2, metavar="N",
                   help="frames drawn as panels, spread over the drives (default 2; 0 = no figures)")
    p.add_argument("--interval-coverage", type=float, default=0.9, metavar="C",
                   help="nominal coverage of the interval files beside the predictions (<name>_low.png and "
                        "<name>_high.png, or <name>_std.png), when the folder has them (default 0.9)")
    add_common_options(p)
    p.set_defaults(func=cmd_score, on_interrupt=_score_interrupted)


def _score_interrupted(args: argparse.Namespace) -> str:
    rows = Path(args.out) / "rows"
    if not rows.is_dir():  # stopped while the predictions were being checked
        return "nothing was written"
    return f"the rows scored so far are kept in {rows}; rerun the same command to resume"


def cmd_score(args: argparse.Namespace) -> int:
    """Run ``inpaintenv score``."""
    from ..benchmark.figure_files import write_figures
    from ..benchmark.figures import DISTANCE_FRAMES, spread_indices
    from ..benchmark.html import write_html_report
    from ..benchmark.kept_frames import KeptFrames
    from ..data.inputs import INPUTS
    from ..benchmark.headline import headline_markdown, headline_title, learned_vs_classical
    from ..files.lock import run_lock
    from ..files.ownership import check_folder
    from ..benchmark.report import summary_table, table_keys, to_markdown, write_report
    from ..benchmark.runner import run_benchmark
    from ..benchmark.suites import LazyMethod, build_method
    from ..conventions import check_int
    from ..metrics import check_coverage
    from ..methods.registry import unfilled_policy
    from ..submission.score import (
        check_run_folder,
        prepare,
        submission_meta,
        without_ms,
    )

    log = (lambda msg: None) if args.quiet else (lambda msg: print(msg, file=sys.stderr))
    # Every option, the manifest, the ground truth and every prediction are checked before
    # the run folder is touched: a bad submission leaves nothing half-written.
    check_int(args.batch_size, "--batch-size", minimum=1)
    check_int(args.figure_frames, "--figure-frames", minimum=0)
    coverage = check_coverage(args.interval_coverage, "--interval-coverage")  # once, here: the run takes it as it is
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise InvalidInputError(f"--out {out} is a file; give a folder for the run")
    names = check_method_names(args.method or [])
    if args.name in names:
        raise InvalidInputError(f"--name {args.name!r} is also given by -m; give the predictions another name")
    methods: dict[str, Any] = {
        name: LazyMethod(lambda name=name: build_method(name, {}), unfilled=unfilled_policy(name)) for name in names
    }
    methods.update(checkpoint_methods(args.checkpoint, [*names, args.name]))
    manifest, dataset, checked = prepare(
        args.manifest, args.predictions, name=args.name, kitti_root=args.kitti_root,
        on_missing=args.on_missing, allow_unfilled=args.allow_unfilled, progress=not args.quiet,
    )
    if checked.missing or checked.unexpected:
        log(f"{args.name}: {checked.left_out()} (--on-missing skip); results.json lists them")
    out = check_run_folder(out, manifest, args.predictions)
    check_folder(out)  # someone else's folder is refused before the lock file is made in it
    run_methods = {args.name: checked.method, **methods}
    protocol, seeds = manifest.protocol_name, manifest.seeds
    figures = args.figure_frames > 0 and manifest.input_kind == "map"
    # Panels only of frames the submission has a prediction for under the first seed.
    absent = {i for i in range(len(dataset)) if (seeds[0], i) not in checked.method.scored_pairs}
    # The figures draw the predictions the run makes of their frames (the submission's files as read for
    # scoring), not the methods called again.
    kept = KeptFrames({dataset.input_kind: spread_indices(dataset, max(args.figure_frames, DISTANCE_FRAMES), absent)},
                      seeds[0]) if figures else None
    with run_lock(out, log):
        result = run_benchmark(
            run_methods, dataset, protocols=[protocol], seeds=seeds, out_dir=out, resume=not args.no_resume,
            batch_size=args.batch_size, progress=not args.quiet, log=log,
            # Only a folder with interval files asks for intervals: one without keeps the run it always had.
            interval_coverage=coverage if checked.method.interval_kind is not None else None, kept=kept,
        )
        report = without_ms(result, args.name)  # the rows keep the time spent reading the files
        command = "inpaintenv " + " ".join(getattr(args, "argv", []))
        paths = write_report(report, out, meta={
            "command": command, "submission": submission_meta(args.name, manifest, args.predictions, checked)})
        keys = table_keys(report)  # an export of scans: the input kind beside the protocol
        table = summary_table(report, keys)
        print(to_markdown(table, keys))
        compared = learned_vs_classical(report)
        if compared:
            what = "hole RMSE" if all(r["task"] == "hole" for r in compared) else "RMSE of the task"
            print(f"\n{headline_title(compared)} ({what} ratio, paired 95 % CI):\n" + headline_markdown(compared))
        if args.figure_frames > 0 and not figures:
            log("no figures: they are drawn for exports of maps only (the panels show a map input)")
        elif figures:
            fig_dir = out / "figures"
            write_figures(
                result, {n: (lambda m=m: m() if getattr(m, "lazy", False) else m) for n, m in run_methods.items()},
                dataset, fig_dir, panel_methods=list(figure_methods(table, run_methods)), n_panels=args.figure_frames,
                protocol=protocol, seed=seeds[0], log=log, exclude=absent, unfilled=result.meta.get("unfilled", {}),
                kept=kept.lookup(INPUTS[dataset.input_kind].label(protocol)),
            )
            log(f"figures in {fig_dir}")
        log(f"wrote {paths['json']}, {paths['csv']}, {paths['markdown']}")
        write_html_report(out, log)
    return 0
