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

from .cli_options import add_common_options, add_source_options, open_source_from_args
from .cluster import ClusterError, add_scheduler_option, open_client, parse_scheduler
from .conventions import DEFAULT_MAX_DEPTH, check_max_depth, check_seed, check_seeds
from .data.base import as_dataset
from .method_options import (
    add_bad_frame_option,
    add_checkpoint_option,
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
    from .registry import make_method
    from .tables import summary_table, table_to_csv

    # Check the options and build every method first, so a typo fails before any long run.
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
    methods = [(name, make_method(name, **_method_overrides(args))) for name in names]
    methods += [(name, make_method("checkpoint", path=path)) for name, path in checkpoints.items()]
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
                     on_bad_frame=args.on_bad_frame, client=client)
            for name, method in methods
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
    from .metrics import frame_metrics
    from .registry import make_method

    out = Path(args.out)
    # OpenCV picks the format from the suffix and fails with its own traceback otherwise.
    if out.suffix.lower() != ".png" or out.is_dir():
        raise ValueError(f"--out must be a .png file, got {args.out!r}")
    check_max_depth(args.max_depth, "--max-depth")
    check_seed(args.seed, "--seed")
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
        pred = batch[0]
        m = {k: float(v) for k, v in frame_metrics(pred, gt, hole, max_depth=args.max_depth).items()}
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


# ---------------------------------------------------------------------------------------
# train
# ---------------------------------------------------------------------------------------
def add_train(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "train", help="train a neural estimator from a named preset",
        description=(
            "Train a neural inpainter with a named recipe (see --list). Writes the model "
            "(safetensors + JSON), resumable checkpoints, training_log.json and loss.png. "
            "Rerun the same command to resume an interrupted run."
        ),
    )
    p.add_argument("--preset", default="blend-kitti",
                   help="training recipe (default blend-kitti, the shipped kitti-rect-v4; --list shows all)")
    p.add_argument("--list", action="store_true", help="list the presets and exit")
    p.add_argument("--out", default="runs/model", metavar="DIR", help="output folder (default runs/model)")
    p.add_argument("--max-steps", type=int, metavar="N", help="override the preset's step budget")
    p.add_argument("--seed", type=int, metavar="S", help="override the preset's random_state")
    p.add_argument("--threads", type=int, metavar="N", help="torch threads (override)")
    p.add_argument("--jobs", type=int, metavar="N",
                   help="frames whose training features are computed in parallel (override of n_jobs; "
                        "blend presets; -1 = all cores)")
    p.add_argument("--device", choices=["auto", "cpu", "cuda"], help="override the preset's device")
    add_source_options(p)
    add_common_options(p)
    p.set_defaults(func=cmd_train, on_interrupt=_train_interrupted)


def _train_interrupted(args: argparse.Namespace) -> str:
    return (f"the checkpoints written so far are kept in {Path(args.out) / 'checkpoints'} (one at the end of "
            "every epoch); rerun the same command to resume from the last one")


#: The record of a training command in its --out, compared by the next run there.
TRAIN_ARGS_FILE = "train_args.json"
#: Overrides that do not change what is trained (the estimators leave them out of the
#: key of their checkpoint folders, so a change still resumes).
#: Overrides that change how fast, not what, is trained (a rerun with another value resumes).
_RUN_INDEPENDENT_OVERRIDES = ("num_threads", "n_jobs")
_OVERRIDE_FLAGS = {"max_steps": "--max-steps", "random_state": "--seed", "num_threads": "--threads",
                   "n_jobs": "--jobs", "device": "--device"}


def train_resume_note(out: Path, record: dict[str, Any]) -> str:
    """Whether ``inpaintenv train`` into ``out`` resumes or starts over, and why.

    ``record`` (preset, overrides, source) is compared with the one the previous run in
    ``out`` left in :data:`TRAIN_ARGS_FILE`. Training checkpoints are keyed by every
    parameter that shapes the run (``--max-steps`` included), so any difference starts a
    new run; the same command continues from the last checkpoint.
    """
    ckpts = out / "checkpoints"
    has_ckpt = ckpts.is_dir() and any(ckpts.rglob("state.json"))
    path = out / TRAIN_ARGS_FILE
    try:
        previous = json.loads(path.read_text()) if path.is_file() else None
    except (ValueError, OSError):
        previous = None

    def keyed(r: dict[str, Any]) -> dict[str, Any]:
        over = {k: v for k, v in (r.get("overrides") or {}).items() if k not in _RUN_INDEPENDENT_OVERRIDES}
        return {"preset": r.get("preset"), "overrides": over, "source": r.get("source")}

    if previous is None:
        if has_ckpt:
            return (f"{ckpts} holds checkpoints of an earlier run: training resumes from them if the preset, "
                    "overrides and data are the same, and starts over otherwise")
        return f"starting a new training run in {out}"
    before, now = keyed(previous), keyed(record)
    if before == now:
        if has_ckpt:
            return f"resuming the run in {out}: same preset, overrides and data, so training continues from its last checkpoint"
        return f"restarting the run in {out} from step 0: same settings, but it stopped before its first checkpoint"
    changes = []
    for key in ("preset", "source"):
        if before[key] != now[key]:
            changes.append(f"--{'preset' if key == 'preset' else 'data'} changed ({before[key]} -> {now[key]})")
    for key in sorted(set(before["overrides"]) | set(now["overrides"])):
        old, new = before["overrides"].get(key, "preset's"), now["overrides"].get(key, "preset's")
        if old != new:
            changes.append(f"{_OVERRIDE_FLAGS.get(key, key)} changed ({old} -> {new})")
    return (f"starting over in {out}: {'; '.join(changes)}. Checkpoints are keyed by every training parameter, "
            f"so the earlier run is not continued (its checkpoints stay in {ckpts})")


def plot_training(history: dict[str, Any], path: Path, title: str) -> Path:
    """Loss per step (raw and smoothed) and validation hole RMSE per epoch, to PNG."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    steps = np.asarray(history.get("step_loss") or [], dtype=float)
    fig, ax = plt.subplots(figsize=(7, 4))
    if steps.size:
        ax.plot(np.arange(1, steps.size + 1), steps, alpha=0.3, lw=0.8, label="loss per step")
        k = max(1, steps.size // 50)
        smooth = np.convolve(steps, np.ones(k) / k, mode="valid")
        ax.plot(np.arange(k, steps.size + 1), smooth, lw=1.5, label=f"mean of {k} steps")
        ax.set_xlabel("step")
    else:  # estimators trained by epochs over pooled samples (BlendInpainter) log epoch losses only
        epochs = np.asarray(history.get("epoch_loss") or [], dtype=float)
        ax.plot(np.arange(1, epochs.size + 1), epochs, "o-", label="loss per epoch")
        ax.set_xlabel("epoch")
    ax.set_ylabel("training loss")
    ax.grid(alpha=0.3)
    val = [v for v in history.get("val_hole_rmse") or [] if v is not None]
    if val:
        ax2 = ax.twinx()
        ax2.plot(np.linspace(0, max(steps.size, 1), len(val) + 1)[1:], val, "o-", color="C3", label="validation hole RMSE")
        ax2.set_ylabel("validation hole RMSE (m)")
        ax2.legend(loc="upper center", fontsize=8)
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def cmd_train(args: argparse.Namespace) -> int:
    from estimators.presets import available_presets, describe_preset, train_preset

    if args.list:
        for name in available_presets():
            print(f"{name:18s} {describe_preset(name)}")
        return 0
    describe_preset(args.preset)  # unknown name: one-line error listing the presets
    overrides: dict[str, Any] = {}
    for key, value in (("max_steps", args.max_steps), ("random_state", args.seed),
                       ("num_threads", args.threads), ("n_jobs", args.jobs), ("device", args.device)):
        if value is not None:
            overrides[key] = value
    ds = open_source_from_args(args)
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} is a file; give a folder")
    out.mkdir(parents=True, exist_ok=True)
    record = {"preset": args.preset, "overrides": overrides, "source": repr(ds)}
    print(train_resume_note(out, record), file=sys.stderr)
    (out / TRAIN_ARGS_FILE).write_text(json.dumps(record, indent=1))
    print(f"training preset {args.preset} on {ds!r} -> {out}", file=sys.stderr)
    est = train_preset(args.preset, ds, checkpoint_dir=out / "checkpoints", verbose=not args.quiet, **overrides)
    model_path = est.save(out / "model")
    history = getattr(est, "history_", None) or {}
    log = {
        "command": "inpaintenv " + " ".join(getattr(args, "argv", [])),
        "preset": args.preset,
        "overrides": overrides,
        "estimator": type(est).__name__,
        "params": {k: repr(v) if not isinstance(v, (int, float, str, bool, type(None), list, tuple)) else v
                   for k, v in est.get_params().items()},
        "source": repr(ds),
        "fit_seconds": getattr(est, "fit_seconds_", None),
        "n_steps": getattr(est, "n_steps_", None),
        "pixels_per_sample": getattr(est, "pixels_per_sample_", None),  # blend presets: below max_pixels?
        "stages": getattr(est, "stages_", None),
        "history": history,
    }
    from .evaluate import json_safe

    (out / "training_log.json").write_text(json.dumps(json_safe(log), indent=1))
    plot_training(history, out / "loss.png", f"{args.preset} on {ds!r}")
    print(f"model: {model_path}")
    print(f"log: {out / 'training_log.json'}, curves: {out / 'loss.png'}")
    print(f"score it: inpaintenv benchmark --checkpoint mine={model_path} ...")
    return 0


SUBCOMMANDS: list[Callable[[Any], None]] = [add_info, add_evaluate, add_show, add_benchmark, add_train]


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
