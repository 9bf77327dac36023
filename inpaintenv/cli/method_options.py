"""Options naming the methods of a run, shared by ``inpaintenv evaluate``, ``benchmark`` and ``score``.

``--checkpoint NAME=PATH`` (a saved neural model), ``--on-bad-frame``, ``--unfilled``, and the checks
of ``--method`` names. Every name and path is resolved here, before any frame is scored,
so a typo fails in a second instead of after an hour of other methods. The subcommand
modules of :mod:`inpaintenv.cli` import this one; it imports none of them.
"""

from __future__ import annotations

import argparse
import inspect
import os
import stat
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..methods.registry import canonical_name, resolve_class
from ..exceptions import InvalidInputError, UnsafeFileError
from ..files import describe_kind

__all__ = [
    "BAD_FRAME_CHOICES", "CHECKPOINT_FOLDER", "UNFILLED_CHOICES", "add_bad_frame_option", "add_checkpoint_option",
    "add_unfilled_option", "check_checkpoint_folder", "check_method_names", "checkpoint_methods", "figure_methods",
    "parse_checkpoints",
]

#: What a checkpoint folder holds, for error messages.
CHECKPOINT_FOLDER = (
    "a checkpoint folder holds model.safetensors and config.json (written by `inpaintenv train` "
    "as <out>/model, or by .save()), or is a training run folder with state.json"
)
#: Values of ``--on-bad-frame``.
BAD_FRAME_CHOICES = ("error", "skip")
#: Values of ``--unfilled`` (:data:`inpaintenv.metrics.UNFILLED`).
UNFILLED_CHOICES = ("error", "interpolate", "zero")


def add_checkpoint_option(parser: argparse.ArgumentParser) -> None:
    """``--checkpoint NAME=PATH`` (repeatable)."""
    parser.add_argument("--checkpoint", action="append", metavar="NAME=PATH", default=[],
                        help="also score a saved neural model (its folder) under NAME (repeatable)")


def add_bad_frame_option(parser: argparse.ArgumentParser) -> None:
    """``--on-bad-frame error|skip``."""
    parser.add_argument(
        "--on-bad-frame", choices=BAD_FRAME_CHOICES, default="error",
        help="an unreadable ground-truth frame (corrupt or 8-bit PNG) stops the run (error, the default) "
             "or is skipped and listed in the report and results.json (skip)",
    )


def add_unfilled_option(parser: argparse.ArgumentParser) -> None:
    """``--unfilled error|interpolate|zero`` (default: each method's registered policy)."""
    parser.add_argument(
        "--unfilled", choices=UNFILLED_CHOICES,
        help="a reconstruction left at 0 m at a hole pixel with ground truth: stop with a count (error), fill it "
             "by the KITTI devkit's background interpolation first (interpolate), or score it as 0 m (zero); "
             "default: error, but zero for the study's hole-only baselines (telea-hole, ns-hole, bilateral-hole)",
    )


def check_method_names(names: Sequence[str]) -> list[str]:
    """The canonical names of ``--method`` values, each checked to be importable.

    Aliases become the name they stand for (rows are recorded under it); nothing is
    built, so no weights are loaded.

    Raises
    ------
    ValueError
        For ``checkpoint`` (it needs a path: ``--checkpoint NAME=PATH``) or a repeated name.
    KeyError, ImportError
        For an unknown name or a method whose module cannot be imported.
    """
    out: list[str] = []
    for name in names:
        canonical = canonical_name(name)
        if canonical == "checkpoint":
            raise InvalidInputError("-m checkpoint needs a path: pass --checkpoint NAME=PATH instead "
                             f"({CHECKPOINT_FOLDER})")
        _check_custom(name, resolve_class(canonical))
        if canonical in out:
            raise InvalidInputError(f"method {name!r} is given twice (as {canonical!r})")
        out.append(canonical)
    return out


def _check_custom(name: str, obj: Any) -> None:
    """Refuse a ``module:attr`` that cannot be a method: a built-in (C) function such as ``os:system``, or
    something not callable. A class, a Python function ``depth -> depth`` or an object with ``predict`` passes."""
    if ":" not in name:
        return
    if callable(getattr(obj, "predict", None)) or isinstance(obj, type):
        return
    if inspect.isbuiltin(obj) or not callable(obj):
        what = "a built-in function" if inspect.isbuiltin(obj) else f"a {type(obj).__name__}, not callable"
        raise InvalidInputError(f"-m {name}: {what}, not a depth method; give a class with predict (an estimator), "
                                "an object with predict, or a Python function depth -> depth (module:name)")


def check_checkpoint_folder(path: str | Path, name: str = "--checkpoint") -> Path:
    """``path`` if it is a checkpoint folder (see :data:`CHECKPOINT_FOLDER`), else one clear error.

    Raises
    ------
    FileNotFoundError
        If nothing is at ``path``.
    ValueError
        If ``path`` is a file (e.g. the ``model.safetensors`` inside the folder) or a
        folder without a model.
    """
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"{name}: checkpoint not found: {p}; {CHECKPOINT_FOLDER}")
    if not p.is_dir():
        hint = f" (pass its folder {p.parent})" if p.name in ("model.safetensors", "config.json") else ""
        raise InvalidInputError(f"{name}: {p} is a file, not a checkpoint folder{hint}; {CHECKPOINT_FOLDER}")
    for member in ("model.safetensors", "config.json", "state.json"):
        _check_member(p / member, name)
    has_model = (p / "model.safetensors").is_file() and (p / "config.json").is_file()
    if not has_model and not (p / "state.json").is_file():
        raise InvalidInputError(f"{name}: {p} is not a checkpoint folder; {CHECKPOINT_FOLDER}")
    return p


def _check_member(path: Path, name: str) -> None:
    """Refuse a file of a checkpoint folder that is there but not a regular file (a FIFO, a device)."""
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return  # missing (or a broken link): the folder's own check names what is missing
    if not stat.S_ISREG(mode):
        raise UnsafeFileError(f"{name}: {path} is {describe_kind(mode)}, not a regular file; {CHECKPOINT_FOLDER}")


def parse_checkpoints(specs: Sequence[str], taken: Sequence[str] = ()) -> dict[str, Path]:
    """``--checkpoint NAME=PATH`` values as ``{name: folder}``, every folder checked.

    Parameters
    ----------
    specs : sequence of str
        The option's values.
    taken : sequence of str
        Method names already in the run (a checkpoint may not reuse one).

    Raises
    ------
    ValueError
        Malformed value, a name given twice, or a path that is not a checkpoint folder.
    FileNotFoundError
        A path that does not exist.
    """
    out: dict[str, Path] = {}
    for spec in specs:
        name, sep, path = spec.partition("=")
        if not sep or not name or not path:
            raise InvalidInputError(f"--checkpoint takes NAME=PATH, got {spec!r}")
        if name in out or name in taken:
            raise InvalidInputError(f"--checkpoint name {name!r} is used twice in this run; give each model its own NAME")
        out[name] = check_checkpoint_folder(path, f"--checkpoint {name}")
    return out


def checkpoint_methods(specs: list[str], taken: list[str]) -> dict[str, Any]:
    """``--checkpoint NAME=PATH`` values as lazily loaded methods of a benchmark run."""
    from ..files.identity import files_identity
    from ..benchmark.suites import LazyMethod
    from ..methods.registry import make_method

    # Hash the files now (cheap) so a resume can tell checkpoints apart unloaded.
    return {
        name: LazyMethod(lambda path=path: make_method("checkpoint", path=path), identity=files_identity(path))
        for name, path in parse_checkpoints(specs, taken).items()
    }


def figure_methods(
    table: list[dict[str, Any]], methods: dict[str, Any], k: int = 4, metric: str = "hole_rmse",
) -> dict[str, Any]:
    """The best ``k`` methods by ``metric`` (the task's RMSE; first protocol of the table), for readable
    panels; none for an empty table.

    A table is empty when no frame could be scored (every frame unreadable and skipped).
    """
    if not table:
        return {}
    first = table[0]["protocol"]
    ranked = sorted(
        (e for e in table if e["protocol"] == first and np.isfinite(e.get(metric, np.nan))),
        key=lambda e: e[metric],
    )
    return {e["method"]: methods[e["method"]] for e in ranked[:k]}
