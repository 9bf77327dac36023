"""``inpaintenv export`` and ``inpaintenv score``: a benchmark for methods that run anywhere.

``export`` writes the occluded inputs of a data source and protocol as files;
any program writes one prediction per input; ``score`` checks and scores them and writes
the run folder and report of ``inpaintenv benchmark``, with the classical methods given
by ``-m`` scored on the same frames and masks in the same table.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

__all__ = ["add_export", "add_score", "cmd_export", "cmd_score"]


def add_export(subparsers: Any, add_source_options: Callable, add_common_options: Callable) -> None:
    """Declare ``inpaintenv export``."""
    from ..benchmark.command import SYNTHETIC_HOLDOUT

    p = subparsers.add_parser(
        "export", help="write the occluded inputs as PNG files for a method run elsewhere",
        description=(
            "Write, for every frame and seed, the occluded input as a KITTI 16-bit depth PNG (0 = hole or no "
            "measurement) and the hole mask as an 8-bit PNG, in KITTI's folder layout, plus manifest.json. "
            "Ground truth is never exported. Score the predictions with `inpaintenv score`."
        ),
    )
    p.add_argument("--protocol", default="rect-v1", help="occlusion protocol (default rect-v1)")
    p.add_argument("--seed", type=int, action="append", metavar="S", help="evaluation seed (repeatable; default 0)")
    p.add_argument("--holdout", type=float, metavar="FRACTION",
                   help=f"export only the drive-level test split `inpaintenv benchmark` scores (default "
                        f"{SYNTHETIC_HOLDOUT} for the synthetic source, 0 = all frames)")
    p.add_argument("--out", default="submission-inputs", metavar="DIR",
                   help="folder of the export (default submission-inputs)")
    p.add_argument("--overwrite", action="store_true", help="replace an earlier export in --out")
    add_source_options(p)
    add_common_options(p)
    p.set_defaults(func=cmd_export)


def cmd_export(args: argparse.Namespace) -> int:
    """Run ``inpaintenv export``."""
    from ..benchmark.command import SYNTHETIC_HOLDOUT, _test_split
    from ..cli_options import open_source_from_args
    from ..conventions import check_seeds
    from ..data.synthetic import SyntheticStreets
    from ..masks import get_protocol
    from .export import export

    seeds = check_seeds(args.seed or [0], "--seed")
    get_protocol(args.protocol)
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} is a file; give a folder for the export")
    dataset = open_source_from_args(args)
    # The benchmark's frames: the same test split by default, so rows of both are comparable.
    holdout = args.holdout
    if holdout is None:
        holdout = SYNTHETIC_HOLDOUT if isinstance(dataset, SyntheticStreets) else 0.0
    if not 0.0 <= holdout < 1.0:
        raise ValueError(f"--holdout must be in [0, 1), got {holdout}")
    if holdout > 0:
        dataset = _test_split(dataset, holdout)
    manifest = export(out, dataset, args.protocol, seeds, overwrite=args.overwrite, progress=not args.quiet)
    n_frames = len(manifest.frames)
    print(f"exported {len(manifest.items)} input{'s' * (len(manifest.items) != 1)} ({n_frames} "
          f"frame{'s' * (n_frames != 1)} × {len(seeds)} seed{'s' * (len(seeds) != 1)}, protocol "
          f"{manifest.protocol_name}) to {out}")
    print(f"each prediction goes to <predictions>/<input's path>, e.g. {manifest.items[0].input}")
    print(f"then: inpaintenv score --manifest {manifest.path} --predictions <predictions> --name <method>")
    return 0


def add_score(subparsers: Any, add_common_options: Callable) -> None:
    """Declare ``inpaintenv score`` (no data-source options: the manifest names the data)."""
    from ..method_options import add_checkpoint_option
    from .predictions import ON_MISSING

    p = subparsers.add_parser(
        "score", help="score a folder of predictions for an export",
        description=(
            "Check a folder of predictions against an export's manifest and its ground truth, score them with the "
            "metrics of `evaluate`, and write the run folder and report of `inpaintenv benchmark` (results.json, "
            ".csv, .md, figures). Methods given by -m are scored on the same frames and masks in the same table. "
            "Resumable: rerun the same command to continue."
        ),
    )
    p.add_argument("--manifest", required=True, metavar="PATH", help="manifest.json of the export (or its folder)")
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
    add_common_options(p)
    p.set_defaults(func=cmd_score, on_interrupt=_score_interrupted)


def _score_interrupted(args: argparse.Namespace) -> str:
    rows = Path(args.out) / "rows"
    if not rows.is_dir():  # stopped while the predictions were being checked
        return "nothing was written"
    return f"the rows scored so far are kept in {rows}; rerun the same command to resume"


def cmd_score(args: argparse.Namespace) -> int:
    """Run ``inpaintenv score``."""
    from ..benchmark.command import _checkpoint_methods, _figure_methods
    from ..benchmark.figures import write_figures
    from ..benchmark.headline import headline_markdown, learned_vs_classical
    from ..benchmark.lock import run_lock
    from ..benchmark.report import summary_table, to_markdown, write_report
    from ..benchmark.runner import run_benchmark
    from ..benchmark.suites import LazyMethod, build_method
    from ..conventions import check_int
    from ..method_options import check_method_names
    from ..registry import unfilled_policy
    from .score import check_run_folder, prepare, submission_meta, without_ms

    log = (lambda msg: None) if args.quiet else (lambda msg: print(msg, file=sys.stderr))
    # Every option, the manifest, the ground truth and every prediction are checked before
    # the run folder is touched: a bad submission leaves nothing half-written.
    check_int(args.batch_size, "--batch-size", minimum=1)
    check_int(args.figure_frames, "--figure-frames", minimum=0)
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} is a file; give a folder for the run")
    names = check_method_names(args.method or [])
    if args.name in names:
        raise ValueError(f"--name {args.name!r} is also given by -m; give the predictions another name")
    methods: dict[str, Any] = {
        name: LazyMethod(lambda name=name: build_method(name, {}), unfilled=unfilled_policy(name)) for name in names
    }
    methods.update(_checkpoint_methods(args.checkpoint, [*names, args.name]))
    manifest, dataset, checked = prepare(
        args.manifest, args.predictions, name=args.name, kitti_root=args.kitti_root,
        on_missing=args.on_missing, allow_unfilled=args.allow_unfilled, progress=not args.quiet,
    )
    if checked.missing or checked.unexpected:
        log(f"{args.name}: {checked.left_out()} (--on-missing skip); results.json lists them")
    out = check_run_folder(out, manifest, args.predictions)
    run_methods = {args.name: checked.method, **methods}
    protocol, seeds = manifest.protocol_name, manifest.seeds
    with run_lock(out, log):
        result = run_benchmark(
            run_methods, dataset, protocols=[protocol], seeds=seeds, out_dir=out, resume=not args.no_resume,
            batch_size=args.batch_size, progress=not args.quiet, log=log,
        )
        report = without_ms(result, args.name)  # the rows keep the time spent reading the files
        command = "inpaintenv " + " ".join(getattr(args, "argv", []))
        paths = write_report(report, out, meta={
            "command": command, "submission": submission_meta(args.name, manifest, args.predictions, checked)})
        table = summary_table(report)
        print(to_markdown(table))
        headline = headline_markdown(learned_vs_classical(report))
        if headline:
            print("\nBest learned vs strongest classical (hole RMSE ratio, paired 95 % CI):\n" + headline)
        if args.figure_frames > 0:
            # Panels only of frames the submission has a prediction for under the first seed.
            absent = {i for i in range(len(dataset)) if (seeds[0], i) not in checked.method.scored_pairs}
            fig_dir = out / "figures"
            write_figures(
                result, {n: (lambda m=m: m() if getattr(m, "lazy", False) else m) for n, m in run_methods.items()},
                dataset, fig_dir, panel_methods=list(_figure_methods(table, run_methods)), n_panels=args.figure_frames,
                protocol=protocol, seed=seeds[0], log=log, exclude=absent, unfilled=result.meta.get("unfilled", {}),
            )
            log(f"figures in {fig_dir}")
        log(f"wrote {paths['json']}, {paths['csv']}, {paths['markdown']}")
    return 0
