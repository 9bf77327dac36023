"""Checkpoint files of the neural inpainters: safetensors + JSON, atomic, never pickle.

A checkpoint is a directory::

    model.safetensors      network weights
    config.json            format tag, estimator class and parameters, fitted attributes,
                           and the SHA-256 of model.safetensors and of training.json
                           (written last: the commit)
    optimizer.safetensors  optional, Adam state tensors (for resuming training)
    training.json          optional, step / epoch / position / history + optimizer groups,
                           and the SHA-256 of both tensor files

Every file is read and written through :mod:`inpaintenv.files`: reads take regular files
only (a FIFO is refused at once, never waited on), JSON is bounded in size and nesting,
tensor files in size, and every write goes to an exclusively created, unpredictably named
temporary file renamed into place, never through a planted link. The JSON files record the SHA-256 of the tensor files they belong to, so a torn,
truncated or edited checkpoint fails to load with :class:`CheckpointError` instead of
producing a silently different model.

A training run directory holds immutable checkpoint directories ``ckpt-<step>-<tag>``,
each written whole under a temporary name and renamed into place (a full disk or a kill
leaves no partial checkpoint folder), and a pointer file ``state.json`` =
``{"last": ..., "best": ...}`` that is replaced atomically, so a crash while writing never
leaves ``last`` half-written. What a training state read back may be is
:mod:`~estimators.learned._training_state`'s.

A checkpoint is data from outside: loading one never writes a file, never reads outside
its folder (the pointers of ``state.json`` must be plain names of checkpoint folders of
the run), and refuses weights without a recorded checksum, weights that are not floating
point or not finite, and config entries of the wrong type, each with one
:class:`CheckpointError` naming the file and the key or tensor.

:mod:`~estimators.learned._persistence` gives every learned estimator ``save`` / ``load``
on top of these files; :func:`recorded_class` finds the class a checkpoint records among the classes its
caller knows. The shipped releases are such files under flat names in
:data:`~inpaintenv.methods.learned.RELEASE_DIR`.
"""

from __future__ import annotations

import errno
import hashlib
import json
import os
import re
import shutil
import tempfile
import uuid
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import torch
from safetensors import SafetensorError
from safetensors.torch import load_file, save_file

from inpaintenv.exceptions import UnknownNameError
from inpaintenv.methods.learned import RELEASE_DIR, shipped
from inpaintenv.files import (
    MAX_JSON_BYTES,
    loads_json,
    open_regular,
    read_bytes,
    remove_stale_temporaries,
    write_atomic,
    write_bytes_atomic,
    write_folder_atomic,
    write_json,
    write_text_atomic,
)

from ._checkpoint_checks import CheckpointError, build_checked, check_tensors, config_value, load_weights
from ._limits import MAX_PARAMETERS
from ._training_state import check_form

__all__ = [
    "FORMAT",
    "FORMAT_VERSION",
    "CheckpointError",
    "build_checked",
    "check_not_linked",
    "check_tensors",
    "config_value",
    "load_weights",
    "flatten_optimizer_state",
    "read_checkpoint",
    "read_model",
    "read_run_state",
    "release_folder",
    "unflatten_optimizer_state",
    "write_checkpoint",
    "write_run_checkpoint",
]

FORMAT = "inpaintenv.neural"
FORMAT_VERSION = 1
MODEL_FILE, CONFIG_FILE = "model.safetensors", "config.json"
OPTIM_FILE, TRAINING_FILE = "optimizer.safetensors", "training.json"
STATE_FILE = "state.json"
#: What ``state.json`` may point at: a checkpoint folder of the run itself, by plain name
#: (no separator, no ``..``), as :func:`write_run_checkpoint` names them.
_RUN_ENTRY = re.compile(r"(ckpt|best)-[A-Za-z0-9_-]+")


#: Largest tensor file read: a network of ``MAX_PARAMETERS`` float32 weights with Adam's
#: two moments (an optimizer file), so no file may ask for more memory than a model can use.
MAX_TENSOR_FILE_BYTES = 3 * 4 * MAX_PARAMETERS + (1 << 20)


def _sha256(fd: int) -> str:
    """The SHA-256 of the open file ``fd``, read from its start in chunks."""
    h = hashlib.sha256()
    os.lseek(fd, 0, os.SEEK_SET)
    for chunk in iter(lambda: os.read(fd, 1 << 20), b""):
        h.update(chunk)
    return h.hexdigest()


def _write_json(path: Path, obj: dict[str, Any]) -> None:
    write_json(path, obj)


def _save_tensors(flat: dict[str, torch.Tensor], path: Path) -> None:
    """safetensors' ``save_file``, its write failures as the OSError they are (a full disk: ENOSPC)."""
    try:
        save_file(flat, str(path))
    except SafetensorError as e:
        # safetensors reports an I/O failure as "... (os error 28)" in its own exception class.
        code = re.search(r"os error (\d+)", str(e))
        if code is None:
            raise OSError(errno.EIO, f"safetensors could not write the file: {e}") from None
        raise OSError(int(code.group(1)), os.strerror(int(code.group(1)))) from None


def _write_tensors(path: Path, tensors: dict[str, torch.Tensor]) -> str:
    flat = {k: v.detach().to("cpu").contiguous() for k, v in tensors.items()}
    write_atomic(path, lambda tmp: _save_tensors(flat, tmp), "checkpoint tensors")
    fd = open_regular(path, "checkpoint tensors")
    try:
        return _sha256(fd)
    finally:
        os.close(fd)


def _read_json(path: Path, owned: bool = False, sha256: str | None = None) -> dict[str, Any]:
    """A checkpoint's JSON file: a regular file, bounded in size and nesting, holding an object
    (not read through a link when the folder is the command's own: ``owned``; its bytes
    checked against ``sha256`` when given)."""
    try:
        data = read_bytes(path, "checkpoint file", limit=MAX_JSON_BYTES, follow_links=not owned)
        if sha256 is not None and hashlib.sha256(data).hexdigest() != sha256:
            raise CheckpointError(f"{path} does not match the checksum recorded in {CONFIG_FILE} beside it: the "
                                  "training state was edited, truncated or partly overwritten")
        obj = loads_json(data, f"checkpoint file {path}")
    except FileNotFoundError:
        raise CheckpointError(f"checkpoint file missing: {path}") from None
    except (ValueError, OSError) as e:  # a FIFO, a folder, too large, too deep, not JSON: named by the file layer
        if isinstance(e, CheckpointError):
            raise
        raise CheckpointError(str(e) if str(path) in str(e) else f"{path}: {e}") from None
    if not isinstance(obj, dict):
        raise CheckpointError(f"checkpoint file {path} does not hold a JSON object")
    return obj


def _read_tensors(path: Path, sha256: Any, recorded_in: Path, owned: bool = False) -> dict[str, torch.Tensor]:
    """The tensors of ``path``, after checking them against the checksum ``recorded_in`` holds."""
    if not isinstance(sha256, str):
        # Without a checksum an edited file would load as a silently different model.
        raise CheckpointError(f"{recorded_in} records no SHA-256 of {path.name} (key {_sha_key(path)!r}): "
                              "the file cannot be verified; save the model again")
    try:
        fd = open_regular(path, "checkpoint tensors", follow_links=not owned)
    except FileNotFoundError:
        raise CheckpointError(f"checkpoint file missing: {path}") from None
    except (ValueError, OSError) as e:
        raise CheckpointError(str(e)) from None
    try:
        opened = os.fstat(fd)
        if opened.st_size > MAX_TENSOR_FILE_BYTES:
            raise CheckpointError(f"{path} is {opened.st_size:,} bytes, more than the {MAX_TENSOR_FILE_BYTES:,} a "
                                  "model this package builds can need; not read")
        if _sha256(fd) != sha256:
            raise CheckpointError(
                f"{path} does not match the checksum recorded beside it: the checkpoint is "
                "truncated, corrupt, or was partly overwritten"
            )
        tensors = load_file(str(path), device="cpu")
        now = os.stat(path)
    except (SafetensorError, OSError, ValueError) as e:
        if isinstance(e, CheckpointError):
            raise
        raise CheckpointError(f"cannot read {path} as safetensors (truncated or corrupt): {e}") from None
    finally:
        os.close(fd)
    if (now.st_dev, now.st_ino, now.st_size, now.st_mtime_ns) != \
            (opened.st_dev, opened.st_ino, opened.st_size, opened.st_mtime_ns):
        raise CheckpointError(f"{path} changed while it was read; load it again")
    return tensors


def _sha_key(path: Path) -> str:
    return "optimizer_sha256" if path.name == OPTIM_FILE else "weights_sha256"


def write_checkpoint(
    path: str | os.PathLike,
    config: dict[str, Any],
    weights: dict[str, torch.Tensor],
    *,
    training: dict[str, Any] | None = None,
    optimizer_tensors: dict[str, torch.Tensor] | None = None,
) -> Path:
    """Write a checkpoint directory (created if needed; existing files are replaced).

    Raises
    ------
    OSError
        A file cannot be written (a full disk: ENOSPC), naming it.
    """
    path = Path(path)
    path.mkdir(parents=True, exist_ok=True)
    weights_sha = _write_tensors(path / MODEL_FILE, weights)
    sums = {"weights_sha256": weights_sha}
    if training is not None:
        optim_sha = _write_tensors(path / OPTIM_FILE, optimizer_tensors or {})
        state = json.dumps({**training, "optimizer_sha256": optim_sha, "weights_sha256": weights_sha}, indent=1)
        write_bytes_atomic(path / TRAINING_FILE, state.encode(), "training state")
        sums["training_sha256"] = hashlib.sha256(state.encode()).hexdigest()
    # config.json last: its checksums commit the weights and the training state written above.
    _write_json(path / CONFIG_FILE, {"format": FORMAT, "format_version": FORMAT_VERSION, **config, **sums})
    return path


def read_checkpoint(
    path: str | os.PathLike, *, training: bool = False, owned: bool = False
) -> tuple[dict[str, Any], dict[str, torch.Tensor], dict[str, Any] | None, dict[str, torch.Tensor] | None]:
    """Read a checkpoint directory.

    Parameters
    ----------
    path : path-like
        The checkpoint folder.
    training : bool
        Also read the training state and optimizer tensors.
    owned : bool
        The folder is one the command writes (a training run resuming): a file there
        that is a symbolic link is refused, never followed.

    Returns
    -------
    config, weights, training_state, optimizer_tensors
        The last two are None unless ``training=True`` (then they must exist).

    Raises
    ------
    CheckpointError
        On any missing, truncated, corrupt or foreign file.
    """
    path = Path(path)
    if owned:
        check_not_linked(path)
    if not path.is_dir():
        raise CheckpointError(f"no checkpoint directory at {path}")
    config = _read_json(path / CONFIG_FILE, owned)
    if config.get("format") != FORMAT:
        raise CheckpointError(f"{path} is not an {FORMAT} checkpoint (format={config.get('format')!r})")
    version = config_value(config, "format_version", int, path / CONFIG_FILE)
    if version > FORMAT_VERSION:
        raise CheckpointError(f"{path} has format version {version}; this version reads <= {FORMAT_VERSION}")
    weights = _read_tensors(path / MODEL_FILE, config.get("weights_sha256"), path / CONFIG_FILE, owned)
    check_tensors(weights, path / MODEL_FILE)
    if not training:
        return config, weights, None, None
    recorded = config.get("training_sha256")
    if not isinstance(recorded, str):
        # Without it an edited step, learning rate or history would be trained on silently.
        raise CheckpointError(f"{path / CONFIG_FILE} records no SHA-256 of {TRAINING_FILE} (key 'training_sha256'): "
                              "its training state cannot be verified (written by an earlier version, or edited); "
                              f"delete {path.parent} to train this run from the start")
    state = check_form(_read_json(path / TRAINING_FILE, owned, sha256=recorded), path / TRAINING_FILE)
    if state["weights_sha256"] != config.get("weights_sha256"):
        raise CheckpointError(f"{path}: training state and weights come from different saves")
    optim = _read_tensors(path / OPTIM_FILE, state["optimizer_sha256"], path / TRAINING_FILE, owned)
    return config, weights, state, optim


# -- optimizer state <-> flat tensors + JSON ------------------------------------------
def flatten_optimizer_state(state_dict: dict[str, Any]) -> tuple[dict[str, torch.Tensor], dict[str, Any]]:
    """Split ``optimizer.state_dict()`` into named tensors and a JSON-able rest."""
    tensors: dict[str, torch.Tensor] = {}
    scalars: dict[str, dict[str, Any]] = {}
    for pid, pstate in state_dict["state"].items():
        for key, value in pstate.items():
            if isinstance(value, torch.Tensor):
                tensors[f"{pid}.{key}"] = value
            else:
                scalars.setdefault(str(pid), {})[key] = value
    return tensors, {"param_groups": state_dict["param_groups"], "scalars": scalars}


def unflatten_optimizer_state(tensors: dict[str, torch.Tensor], meta: dict[str, Any]) -> dict[str, Any]:
    """Inverse of :func:`flatten_optimizer_state`."""
    state: dict[int, dict[str, Any]] = {}
    for name, value in tensors.items():
        pid, key = name.split(".", 1)
        state.setdefault(int(pid), {})[key] = value
    for pid, extra in meta.get("scalars", {}).items():
        state.setdefault(int(pid), {}).update(extra)
    return {"state": state, "param_groups": meta["param_groups"]}


# -- training run directories ---------------------------------------------------------
def check_not_linked(folder: Path) -> None:
    """Refuse a folder of a run the command owns that is a symbolic link: through it, a resume
    would read, and the next checkpoint write and delete, in a folder elsewhere."""
    if folder.is_symlink():
        raise CheckpointError(f"{folder} is a symbolic link; a training run reads and writes its checkpoints in "
                              "its own folder only, never through a link")


def read_run_state(run_dir: str | os.PathLike, *, owned: bool = False) -> dict[str, Any] | None:
    """The ``{"last": name, "best": name | None}`` pointers of a run, or None if new
    (``owned``: the run is the command's own, a linked ``state.json`` is refused).

    Raises
    ------
    CheckpointError
        A pointer that is not the plain name of a checkpoint folder of the run (an absolute
        path, ``..``, a separator, a missing ``last``): loading never leaves the run folder.
    """
    if owned:
        check_not_linked(Path(run_dir))
    path = Path(run_dir) / STATE_FILE
    if not path.exists() and not path.is_symlink():
        return None
    state = _read_json(path, owned)
    for key in ("last", "best"):
        value = state.get(key)
        if key == "best" and value is None:
            continue
        if not isinstance(value, str) or not _RUN_ENTRY.fullmatch(value):
            raise CheckpointError(f"{path}: {key!r} must name a checkpoint folder of this run "
                                  f"(ckpt-... or best-..., no path), got {value!r}")
    return state


def write_run_checkpoint(
    run_dir: str | os.PathLike,
    step: int,
    config: dict[str, Any],
    weights: dict[str, torch.Tensor],
    training: dict[str, Any],
    optimizer_tensors: dict[str, torch.Tensor],
    *,
    best_weights: dict[str, torch.Tensor] | None = None,
    best_is_current: bool = False,
) -> None:
    """Write ``last`` (and maybe a new ``best``) of a run and swap the pointers atomically.

    Parameters
    ----------
    best_weights : dict, optional
        Weights of a new best model to write as the ``best`` checkpoint.
    best_is_current : bool
        The current weights are the new best (``best`` points at the new ``last``).
    """
    run_dir = Path(run_dir)
    old = read_run_state(run_dir, owned=True) or {}
    # Fresh names: a referenced checkpoint is never rewritten in place. Each folder is
    # written whole under a temporary name, so a failed write leaves no folder of that name.
    tag = f"{step:08d}-{uuid.uuid4().hex[:8]}"
    last = f"ckpt-{tag}"
    write_folder_atomic(run_dir / last, lambda tmp: write_checkpoint(
        tmp, config, weights, training=training, optimizer_tensors=optimizer_tensors), "training checkpoint",
        within=run_dir.parent)
    best = old.get("best")
    if best_is_current:
        best = last
    elif best_weights is not None:
        best = f"best-{tag}"
        write_folder_atomic(run_dir / best, lambda tmp: write_checkpoint(tmp, config, best_weights),
                            "best checkpoint", within=run_dir.parent)
    write_text_atomic(run_dir / STATE_FILE, json.dumps({"last": last, "best": best}, indent=1) + "\n", "run state",
                      within=run_dir.parent)
    # Only now are older checkpoints unreferenced.
    for child in run_dir.iterdir():
        if child.name not in (last, best) and child.name.startswith(("ckpt-", "best-")) and \
                child.is_dir() and not child.is_symlink():
            shutil.rmtree(child, ignore_errors=True)
    remove_stale_temporaries(run_dir, folders=True)  # a checkpoint folder a killed writer left half-written


def provenance(est: Any) -> dict[str, Any]:
    """What a saved model records about its training data and machine: ``training_drives``
    (None when unknown) and ``environment`` (:func:`inpaintenv.report.provenance.environment_info`
    at fit time; omitted when the model was not fitted in this version)."""
    out: dict[str, Any] = {"training_drives": getattr(est, "training_drives_", None)}
    if getattr(est, "fit_environment_", None) is not None:
        out["environment"] = est.fit_environment_
    return out


def restore_provenance(est: Any, config: dict[str, Any]) -> None:
    """Set ``training_drives_`` and ``fit_environment_`` from a checkpoint's config (None when absent)."""
    drives = config.get("training_drives")
    est.training_drives_ = [str(d) for d in drives] if isinstance(drives, list) else None
    est.fit_environment_ = config.get("environment")


@contextmanager
def release_folder(name: Any, directory: Path = RELEASE_DIR) -> Iterator[Path]:
    """A temporary checkpoint folder holding release ``name``'s two files, as shipped.

    The shipped pair is a checkpoint's files under flat names; copied (they are small)
    into one folder, they are read by the same checksum-verifying loader as any checkpoint.

    Raises
    ------
    KeyError
        No complete release of that name in ``directory`` (the message lists them).
    """
    releases = shipped(directory)
    if not isinstance(name, str) or name not in releases:
        raise UnknownNameError(f"no shipped release {name!r}; shipped: {sorted(releases)}")
    with tempfile.TemporaryDirectory() as tmp:
        for suffix, target in ((".safetensors", MODEL_FILE), (".json", CONFIG_FILE)):
            data = read_bytes(directory / f"{name}{suffix}", "shipped release file", limit=MAX_TENSOR_FILE_BYTES)
            write_bytes_atomic(Path(tmp) / target, data, "release copy")
        yield Path(tmp)


def read_model(path: str | os.PathLike) -> tuple[dict[str, Any], dict[str, torch.Tensor], Path]:
    """The config and checked weights of a model folder, or of a run folder's best (else last)
    checkpoint, and the folder they were read from."""
    path = Path(path)
    state = read_run_state(path) if path.is_dir() else None
    if state is not None:
        path = path / (state.get("best") or state["last"])
    config, weights, _, _ = read_checkpoint(path)
    return config, weights, path


def recorded_class(config: dict[str, Any], where: Any, known: Mapping[str, type]) -> type:
    """The class ``config`` records, looked up in ``known`` (class name -> class).

    Raises
    ------
    CheckpointError
        No class, or one not in ``known`` (this version cannot load it).
    """
    name = config.get("class")
    klass = known.get(name) if isinstance(name, str) else None
    if klass is None or not hasattr(klass, "_from_config"):
        raise CheckpointError(f"{where} holds a {name!r}, which this version cannot load (known: {sorted(known)})")
    return klass


def with_overrides(est: Any, name: str, overrides: dict[str, Any]) -> Any:
    """``est`` (release ``name``) with prediction-time ``overrides`` set and checked against its weights.

    Raises
    ------
    ValueError
        An override of a parameter the weights depend on, one the estimator does not have,
        or one outside its range (``num_threads=1000``).
    """
    if not overrides:
        return est
    est.set_params(**overrides)
    # Every parameter checked now (a thread count, a negative value), not at the first predict.
    for model in (est, *getattr(est, "estimators_", [])):  # an ensemble's fitted members follow member__param
        for name in ("_check_params", "_check_model_params"):
            if callable(getattr(model, name, None)):
                getattr(model, name)()
    return est


def cpu_state(model: torch.nn.Module, clone: bool = False) -> dict[str, torch.Tensor]:
    """``model``'s state dict on the CPU, contiguous (``clone``: a copy training cannot change)."""
    state = {k: v.detach().to("cpu").contiguous() for k, v in model.state_dict().items()}
    return {k: v.clone() for k, v in state.items()} if clone else state


def progress_history(fitted: dict[str, Any]) -> dict[str, Any]:
    """History stored in a training-run checkpoint summary (or an empty one)."""
    return fitted.get("history") or {"step_loss": [], "epoch_loss": [], "val_hole_rmse": [], "best_epoch": None}
