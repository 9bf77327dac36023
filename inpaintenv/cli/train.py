"""``inpaintenv train``: fit a named preset, resumably, and write the model, its log and curves."""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from ..cluster import open_client, parse_scheduler
from ..files import loads_json
from ..report.provenance import environment_info
from .options import (
    add_common_options,
    add_source_options,
    check_source_options,
    open_source_from_args,
    thread_count,
)
from ..exceptions import FileTooLargeError, InpaintenvError, InvalidInputError, JSONFileError, UnsafeFileError
from ..data.inputs import INPUT_KINDS, input_kind


def add_train(subparsers: Any) -> None:
    """Add the ``train`` subcommand to ``subparsers`` (an ``argparse`` subparsers action)."""
    p = subparsers.add_parser(
        "train", help="train a neural estimator from a named preset",
        description=(
            "Train a neural inpainter with a named recipe (see --list). Writes the model "
            "(safetensors + JSON), resumable checkpoints, training_log.json and loss.png. "
            "Rerun the same command to resume an interrupted run."
        ),
    )
    p.add_argument("--preset", default="ensemble-kitti",
                   help="training recipe (default ensemble-kitti, the recipe of the default release "
                        "kitti-ensemble-v1; --list shows all)")
    p.add_argument("--list", action="store_true", help="list the presets and exit")
    p.add_argument("--out", default="runs/model", metavar="DIR", help="output folder (default runs/model)")
    p.add_argument("--max-steps", type=int, metavar="N", help="override the preset's step budget")
    p.add_argument("--max-minutes", type=float, metavar="M",
                   help="wall-clock budget in minutes of each training stage (step-trained presets): training stops "
                        "after the step during which it ran out, checkpointed; rerunning resumes with a new budget")
    p.add_argument("--seed", type=int, metavar="S", help="override the preset's random_state")
    p.add_argument("--threads", type=thread_count, metavar="N", help="torch threads (override; at most MAX_THREADS)")
    p.add_argument("--jobs", type=int, metavar="N",
                   help="frames whose training features are computed in parallel (override of n_jobs; "
                        "blend presets; -1 = all cores)")
    p.add_argument("--device", choices=["auto", "cpu", "cuda"], help="override the preset's device")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", dest="set_params",
                   help="override any parameter of the preset's estimator, VALUE read as JSON (6, 0.5, true, "
                        "[1.0, 0.6]; anything else is a string); an ensemble member's as member__param, e.g. "
                        "--set context__masks_per_frame=6 (repeatable)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="compute the blend presets' training features on a Dask cluster: tcp://HOST:PORT of a "
                        'running scheduler, or local:N worker processes here (needs pip install "inpaintenv[dask]")')
    p.add_argument("--input", choices=list(INPUT_KINDS), default="map", metavar="KIND",
                   help="what the model learns to fill: map (the ground truth with holes cut, the default) or scan "
                        "(each frame's single LiDAR scan, with or without holes; blend presets only, e.g. blend-kitti)"
                        "; or a sparser LiDAR made from the scan: scan-rings32-v1 / scan-rings16-v1 / scan-rings8-v1 "
                        "(every 2nd / 4th / 8th laser ring), scan-points50-v1 / scan-points25-v1 / scan-points10-v1 "
                        "(a seeded share of its points; docs/protocols.md)")
    add_source_options(p)
    add_common_options(p)
    p.set_defaults(func=cmd_train, on_interrupt=_train_interrupted)


#: Estimators whose ``fit`` takes a dataset of scans (``input_kind == "scan"``): the input is the scan.
SCAN_FITTERS = ("BlendInpainter", "ScanBlendInpainter")


def check_scan_training(preset: str, overrides: dict[str, Any]) -> None:
    """Refuse ``--input scan`` for a preset whose estimator's ``fit`` does not read a scan dataset.

    Raises
    ------
    InvalidInputError
        One line naming the preset, its estimator and the presets that can.
    """
    from estimators.learned.presets import available_presets, make_preset

    try:
        est: Any = make_preset(preset, **overrides)
    except (InpaintenvError, ValueError, KeyError):  # a multi-stage preset trains several estimators
        est = None
    if type(est).__name__ in SCAN_FITTERS:
        return
    able = [n for n in available_presets() if _single_stage_class(n) in SCAN_FITTERS]
    what = f"a {type(est).__name__}" if est is not None else "several stages"
    raise InvalidInputError(f"--input scan: preset {preset} trains {what}, whose fit does not learn from a scan yet; "
                            f"train {' or '.join(able) or 'a blend preset'} on scans, or leave --input out")


def _single_stage_class(name: str) -> str:
    from estimators.learned.presets import make_preset

    try:
        return type(make_preset(name)).__name__
    except (InpaintenvError, ValueError, KeyError):
        return ""


def _joblib_on(client: Any) -> Any:
    """joblib's Dask backend while ``client`` is open (its workers run the joblib tasks), else nothing."""
    if client is None:
        return contextlib.nullcontext()
    import joblib

    return joblib.parallel_backend("dask")


def _train_interrupted(args: argparse.Namespace) -> str:
    """What a Ctrl-C leaves behind: the checkpoints this run wrote, or that it wrote none."""
    ckpts = Path(args.out) / "checkpoints"
    started = getattr(args, "train_started", None)
    states = list(ckpts.rglob("state.json")) if ckpts.is_dir() else []
    if started is None:  # stopped while the arguments were checked
        return "nothing was written"
    if not any(p.stat().st_mtime >= started for p in states):
        earlier = f"; the earlier checkpoints in {ckpts} are untouched" if states else ""
        return (f"no checkpoint was written (this run stopped before its first one, at the end of the first "
                f"epoch){earlier}; rerun the same command to start again")
    return (f"the checkpoints written so far are kept in {ckpts} (one at the end of every epoch); rerun the "
            "same command to resume from the last one")


def _stop_reason(est: Any) -> str | None:
    """Why training stopped before its ``max_steps``, if it did (its epochs ran out), else None."""
    get_params = getattr(est, "get_params", None)
    params = get_params(deep=False) if callable(get_params) else {}
    steps, max_steps, epochs = getattr(est, "n_steps_", None), params.get("max_steps"), params.get("epochs")
    if not isinstance(steps, int) or not isinstance(max_steps, int) or not isinstance(epochs, int) or epochs < 1:
        return None
    if steps >= max_steps or "budget_stop" in (getattr(est, "history_", None) or {}):
        return None  # the estimator said so itself when its max_minutes stopped it
    return (f"training stopped after {steps} of max_steps={max_steps} steps: its {epochs} epoch"
            f"{'s' * (epochs != 1)} ended first ({steps // epochs} steps each, one pass over the training frames "
            f"in batches of {params.get('batch_size', '?')}); --set epochs=N or more frames reach max_steps")


@contextlib.contextmanager
def _plain_progress(quiet: bool) -> Any:
    """Progress bars as plain lines while stderr is a log file (as the benchmark writes there)."""
    from ..progress import PlainLines, stderr_is_terminal

    if quiet or stderr_is_terminal():
        yield
        return
    lines = PlainLines(sys.stderr)
    try:
        with contextlib.redirect_stderr(lines):
            yield
    finally:
        lines.close()


#: The record of a training command in its --out, compared by the next run there.
TRAIN_ARGS_FILE = "train_args.json"
#: Overrides that change how fast, not what, is trained (the estimators leave them out of
#: the key of their checkpoint folders, so a change still resumes).
_RUN_INDEPENDENT_OVERRIDES = ("num_threads", "n_jobs", "max_minutes")
_OVERRIDE_FLAGS = {"max_steps": "--max-steps", "max_minutes": "--max-minutes", "random_state": "--seed",
                   "num_threads": "--threads", "n_jobs": "--jobs", "device": "--device"}


def parse_set_option(item: str) -> tuple[str, Any]:
    """``KEY=VALUE`` of ``--set``: VALUE read as JSON where it parses (numbers, true/false, null,
    lists), else kept as a string (e.g. ``protocol=rect-v1``).

    Raises
    ------
    ValueError
        No ``=``, or an empty or malformed key.
    """
    key, sep, raw = item.partition("=")
    key = key.strip()
    if not sep or not key.isidentifier():
        raise InvalidInputError(f"--set takes KEY=VALUE with KEY a parameter name (member__param for an ensemble's "
                         f"member), got {item!r}")
    try:
        value = loads_json(raw, f"--set {key}")
    except JSONFileError:
        value = raw
    return key, value


def _keyed(r: dict[str, Any]) -> dict[str, Any]:
    """What a run trains: preset, overrides that change the weights, data."""
    over = {k: v for k, v in (r.get("overrides") or {}).items() if k not in _RUN_INDEPENDENT_OVERRIDES}
    return {"preset": r.get("preset"), "overrides": over, "source": r.get("source")}


def _previous_record(out: Path) -> dict[str, Any] | None:
    """What the previous run in ``out`` recorded; None if nothing readable (a new run).

    Raises
    ------
    UnsafeFileError
        :data:`TRAIN_ARGS_FILE` is a link, FIFO or device (never read through or waited on).
    """
    from ..files import read_json

    path = out / TRAIN_ARGS_FILE
    if not os.path.lexists(path):
        return None
    try:
        previous = read_json(path, "training arguments", follow_links=False)
    except (JSONFileError, FileTooLargeError):
        return None  # broken, too deep or too large: not a record to resume from
    return previous if isinstance(previous, dict) else None


def finished_model(out: Path, record: dict[str, Any]) -> Path | None:
    """The model of a run in ``out`` that already finished with the same settings as ``record``, else None.

    A run is finished when :data:`TRAIN_ARGS_FILE` says so (written after the model and
    its log) and the model folder is still there.
    """
    previous = _previous_record(out)
    if not previous or not previous.get("finished") or _keyed(previous) != _keyed(record):
        return None
    model = out / "model"
    return model if (model / "config.json").is_file() else None


def train_resume_note(out: Path, record: dict[str, Any], *, checkpoints: bool = True) -> str:
    """Whether ``inpaintenv train`` into ``out`` resumes or starts over, and why.

    ``record`` (preset, overrides, source) is compared with the one the previous run in
    ``out`` left in :data:`TRAIN_ARGS_FILE`. Training checkpoints are keyed by every
    parameter that shapes the run (``--max-steps`` included), so any difference starts a
    new run; the same command continues from the last checkpoint. ``checkpoints=False``
    (the blend presets: a few minutes, no checkpoints) says so instead of speaking of them.
    """
    ckpts = out / "checkpoints"
    has_ckpt = ckpts.is_dir() and any(ckpts.rglob("state.json"))
    previous = _previous_record(out)
    keyed = _keyed
    if previous is None:
        if has_ckpt:
            return (f"{ckpts} holds checkpoints of an earlier run: training resumes from them if the preset, "
                    "overrides and data are the same, and starts over otherwise")
        return f"starting a new training run in {out}"
    before, now = keyed(previous), keyed(record)
    if before == now:
        if has_ckpt:
            return f"resuming the run in {out}: same preset, overrides and data, so training continues from its last checkpoint"
        if not checkpoints:
            return (f"training again in {out} from the start: the earlier run with the same settings did not finish, "
                    f"and preset {record.get('preset')} keeps no checkpoints (it trains in one pass of minutes)")
        return f"restarting the run in {out} from step 0: same settings, but it stopped before its first checkpoint"
    changes = []
    for key in ("preset", "source"):
        if before[key] != now[key]:
            changes.append(f"--{'preset' if key == 'preset' else 'data'} changed ({before[key]} -> {now[key]})")
    for key in sorted(set(before["overrides"]) | set(now["overrides"])):
        old, new = before["overrides"].get(key, "preset's"), now["overrides"].get(key, "preset's")
        if old != new:
            changes.append(f"{_OVERRIDE_FLAGS.get(key, f'--set {key}')} changed ({old} -> {new})")
    return (f"starting over in {out}: {'; '.join(changes)}. Checkpoints are keyed by every training parameter, "
            f"so the earlier run is not continued (its checkpoints stay in {ckpts})")


def plot_training(history: dict[str, Any], path: Path, title: str, loss_label: str = "training loss") -> Path:
    """Loss per step (raw and smoothed) or per epoch, and validation hole RMSE per epoch, to PNG.

    ``loss_label`` names the loss and its unit on the y axis (an estimator's ``loss_label``).
    """
    import matplotlib.pyplot as plt

    from ..files import write_atomic

    fig = loss_figure(history, title, loss_label)
    try:
        write_atomic(path, lambda tmp: fig.savefig(tmp, dpi=100, format=Path(path).suffix.lstrip(".") or "png"),
                     "loss curve")
    finally:
        plt.close(fig)
    return Path(path)


def loss_figure(history: dict[str, Any], title: str, loss_label: str = "training loss") -> Any:
    """The figure of :func:`plot_training` (integer steps or epochs on the x axis)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator

    steps = np.asarray(history.get("step_loss") or [], dtype=float)
    fig, ax = plt.subplots(figsize=(7, 4))
    if steps.size:
        ax.plot(np.arange(1, steps.size + 1), steps, alpha=0.3, lw=0.8, label="loss per step")
        k = max(1, steps.size // 50)
        smooth = np.convolve(steps, np.ones(k) / k, mode="valid")
        ax.plot(np.arange(k, steps.size + 1), smooth, lw=1.5, label=f"mean of {k} steps")
        ax.set_xlabel("step")
    else:  # estimators trained by epochs over pooled samples (BlendInpainter) log epoch losses only
        # an ensemble (MeanEnsembleInpainter) logs each member's epoch losses
        members = history.get("epoch_loss_by_member") or {"": history.get("epoch_loss") or []}
        for name, losses in members.items():
            epochs = np.asarray(losses, dtype=float)
            ax.plot(np.arange(1, epochs.size + 1), epochs, "o-", label=f"{name} loss per epoch".strip())
        ax.set_xlabel("epoch")
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))  # steps and epochs are counts, never 1.5
    ax.set_ylabel(loss_label)
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
    return fig


def _plain(value: Any) -> bool:
    """Whether ``value`` is written to JSON as is (else its repr is logged, e.g. an ensemble's members)."""
    if isinstance(value, (list, tuple)):
        return all(_plain(v) for v in value)
    return isinstance(value, (int, float, str, bool, type(None)))


def cmd_train(args: argparse.Namespace) -> int:
    """Run ``inpaintenv train``: check the arguments, fit the preset (on ``--scheduler``'s
    workers where given), write the model, ``training_log.json`` and ``loss.png``; returns 0."""
    from ..methods.learned import require_learned

    require_learned("training a learned model")  # one line naming the extra, not torch's ImportError
    from estimators.learned.presets import (
        available_presets,
        check_preset,
        describe_preset,
        preset_runs_joblib,
    )

    if args.list:
        names = available_presets()
        column = max(len(n) for n in names)  # the descriptions start in one column
        for name in names:
            print(f"{name:{column}s}  {describe_preset(name)}")
        return 0
    describe_preset(args.preset)  # unknown name: one-line error listing the presets
    check_source_options(args)
    if args.scheduler is not None:
        parse_scheduler(args.scheduler)
        if not preset_runs_joblib(args.preset):
            raise InvalidInputError(
                f"--scheduler spreads the training features of the blend presets; {args.preset} trains step by "
                "step in one process (several processes or GPUs: torchrun -m estimators.learned.distributed)"
            )
    overrides: dict[str, Any] = {}
    for key, value in (("max_steps", args.max_steps), ("max_minutes", args.max_minutes), ("random_state", args.seed),
                       ("num_threads", args.threads), ("n_jobs", args.jobs), ("device", args.device)):
        if value is not None:
            overrides[key] = value
    from_flags = set(overrides)
    for item in getattr(args, "set_params", None) or []:
        key, value = parse_set_option(item)
        if key in overrides:
            other = _OVERRIDE_FLAGS.get(key, key) if key in from_flags else f"another --set {key}"
            raise InvalidInputError(f"--set {key} is given twice (also as {other}); give it once")
        overrides[key] = value
    # Every parameter is checked before anything is written: a refused --max-steps must not
    # leave a train_args.json behind that the next run compares itself with.
    check_preset(args.preset, **overrides)
    if input_kind(args.input).separate:
        check_scan_training(args.preset, overrides)
    ds = open_source_from_args(args)  # with --input scan, each frame's scan paired with its ground truth
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise InvalidInputError(f"--out {out} is a file; give a folder")
    record = {"preset": args.preset, "overrides": overrides, "source": repr(ds)}
    from ..files.lock import run_lock
    from ..files.ownership import TRAIN, check_folder

    check_folder(out, TRAIN)  # someone else's folder or file is refused before anything is written
    # One run per folder: two trainings into one --out would write the same checkpoints.
    with run_lock(out, lambda msg: print(msg, file=sys.stderr)):
        args.train_started = time.time()
        return _train_locked(args, ds, out, record, overrides)


def _own_folder(out: Path) -> None:
    """Record every file ``train`` writes in ``out`` (its ledger, :mod:`~inpaintenv.files.ownership`)
    before anything is written, and clear the temporaries a killed run left.

    Raises
    ------
    ForeignFolderError
        A file at one of those paths that no training wrote (the message names it).
    UnsafeFileError
        ``model/`` or ``checkpoints/`` is a symbolic link.
    """
    from ..files.ownership import TRAIN, TRAIN_FILES, claim
    from ..files import remove_stale_temporaries

    claim(out, *TRAIN_FILES, kind=TRAIN)
    for sub in ("model", "checkpoints"):
        if (out / sub).is_symlink():
            raise UnsafeFileError(f"{out / sub} is a symbolic link; train writes in its own --out only")
    for folder in (out, out / "model"):
        remove_stale_temporaries(folder)


def _train_locked(args: argparse.Namespace, ds: Any, out: Path, record: dict[str, Any],
                  overrides: dict[str, Any]) -> int:
    """The training itself, holding the lock of ``out``: resume note, fit, model, log and curves."""
    from estimators.learned.presets import preset_checkpoints, train_preset

    from ..report.results import json_safe
    from ..files import write_text_atomic

    _own_folder(out)
    done = finished_model(out, record)
    if done is not None:
        print(f"the run in {out} already finished with the same preset, overrides and data: model {done}, "
              f"log {out / 'training_log.json'}; nothing to do (another --out, or delete {out}, trains again)",
              file=sys.stderr)
        print(f"model: {done}")
        return 0
    out.mkdir(parents=True, exist_ok=True)
    print(train_resume_note(out, record, checkpoints=preset_checkpoints(args.preset)), file=sys.stderr)
    write_text_atomic(out / TRAIN_ARGS_FILE, json.dumps(record, indent=1))
    print(f"training preset {args.preset} on {ds!r} -> {out}", file=sys.stderr)
    with open_client(args.scheduler) as client, _joblib_on(client), _plain_progress(args.quiet):
        est = train_preset(args.preset, ds, checkpoint_dir=out / "checkpoints", verbose=not args.quiet,
                           **overrides)
    reason = _stop_reason(est)
    if reason is not None:
        print(reason, file=sys.stderr)
    model_path = est.save(out / "model")
    history = getattr(est, "history_", None) or {}
    log = {
        "command": "inpaintenv " + " ".join(getattr(args, "argv", [])),
        "preset": args.preset,
        "overrides": overrides,
        "estimator": type(est).__name__,
        "params": {k: v if _plain(v) else repr(v) for k, v in est.get_params(deep=False).items()},
        "source": repr(ds),
        "fit_seconds": getattr(est, "fit_seconds_", None),
        "n_steps": getattr(est, "n_steps_", None),
        "pixels_per_sample": getattr(est, "pixels_per_sample_", None),  # blend presets: below max_pixels?
        "stages": getattr(est, "stages_", None),
        "training_drives": getattr(est, "training_drives_", None),
        # Weights are identical only with the same libraries on the same kind of machine.
        "environment": getattr(est, "fit_environment_", None) or environment_info(torch_details=True),
        "history": history,
    }
    write_text_atomic(out / "training_log.json", json.dumps(json_safe(log), indent=1))
    plot_training(history, out / "loss.png", f"{args.preset} on {ds!r}", getattr(est, "loss_label", "training loss"))
    # Last: a rerun of this command is a no-op only once the model and its log are written,
    # and the run was not stopped by --max-minutes (a rerun then resumes it).
    finished = {} if "budget_stop" in history else {"finished": True}
    write_text_atomic(out / TRAIN_ARGS_FILE, json.dumps({**record, **finished}, indent=1))
    print(f"model: {model_path}")
    print(f"log: {out / 'training_log.json'}, curves: {out / 'loss.png'}")
    print(f"score it: inpaintenv benchmark --checkpoint mine={model_path} ...")
    return 0
