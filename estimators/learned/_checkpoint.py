"""Checkpoint files of the neural inpainters: safetensors + JSON, atomic, never pickle.

A checkpoint is a directory::

    model.safetensors      network weights
    config.json            format tag, estimator class and parameters, fitted attributes,
                           and the SHA-256 of model.safetensors (written last: the commit)
    optimizer.safetensors  optional, Adam state tensors (for resuming training)
    training.json          optional, step / epoch / position / history + optimizer groups

Every file is written to a temporary name and moved into place with ``os.replace``;
the JSON files record the SHA-256 of the tensor files they belong to, so a torn,
truncated or edited checkpoint fails to load with :class:`CheckpointError` instead of
producing a silently different model.

A training run directory holds immutable checkpoint directories ``ckpt-<step>`` and a
pointer file ``state.json`` = ``{"last": ..., "best": ...}`` that is replaced
atomically, so a crash while writing never leaves ``last`` half-written.

A checkpoint is data from outside: loading one never writes a file, never reads outside
its folder (the pointers of ``state.json`` must be plain names of checkpoint folders of
the run), and refuses weights without a recorded checksum, weights that are not floating
point or not finite, and config entries of the wrong type, each with one
:class:`CheckpointError` naming the file and the key or tensor.

:class:`CheckpointMixin` gives the neural inpainters ``save`` / ``load`` on top of these
files; :data:`CLASSES` maps the class name a checkpoint records to its class.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import tempfile
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import torch
from safetensors import SafetensorError
from safetensors.torch import load_file, save_file

from ._checkpoint_checks import CheckpointError, build_checked, check_tensors, config_value, load_weights

__all__ = [
    "FORMAT",
    "FORMAT_VERSION",
    "CheckpointError",
    "build_checked",
    "check_tensors",
    "config_value",
    "load_weights",
    "flatten_optimizer_state",
    "load_shipped",
    "read_checkpoint",
    "read_run_state",
    "release_folder",
    "shipped_releases",
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


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _atomic_write(path: Path, write: Any) -> None:
    """Call ``write(tmp_path)`` then move the temp file over ``path`` atomically."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        write(tmp)
        with open(tmp, "rb+") as f:
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _write_json(path: Path, obj: dict[str, Any]) -> None:
    def write(tmp: str) -> None:
        with open(tmp, "w", encoding="utf-8") as f:
            json.dump(obj, f, indent=1, allow_nan=True)

    _atomic_write(path, write)


def _write_tensors(path: Path, tensors: dict[str, torch.Tensor]) -> str:
    flat = {k: v.detach().to("cpu").contiguous() for k, v in tensors.items()}
    _atomic_write(path, lambda tmp: save_file(flat, tmp))
    return _sha256(path)


def _read_json(path: Path) -> dict[str, Any]:
    try:
        with open(path, encoding="utf-8") as f:
            obj = json.load(f)
    except FileNotFoundError:
        raise CheckpointError(f"checkpoint file missing: {path}") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise CheckpointError(f"checkpoint file {path} is not valid JSON (truncated or corrupt): {e}") from None
    if not isinstance(obj, dict):
        raise CheckpointError(f"checkpoint file {path} does not hold a JSON object")
    return obj


def _read_tensors(path: Path, sha256: Any, recorded_in: Path) -> dict[str, torch.Tensor]:
    """The tensors of ``path``, after checking them against the checksum ``recorded_in`` holds."""
    if not path.is_file():
        raise CheckpointError(f"checkpoint file missing: {path}")
    if not isinstance(sha256, str):
        # Without a checksum an edited file would load as a silently different model.
        raise CheckpointError(f"{recorded_in} records no SHA-256 of {path.name} (key {_sha_key(path)!r}): "
                              "the file cannot be verified; save the model again")
    if _sha256(path) != sha256:
        raise CheckpointError(
            f"{path} does not match the checksum recorded beside it: the checkpoint is "
            "truncated, corrupt, or was partly overwritten"
        )
    try:
        return load_file(str(path), device="cpu")
    except (SafetensorError, OSError, ValueError) as e:
        raise CheckpointError(f"cannot read {path} as safetensors (truncated or corrupt): {e}") from None


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
    """Write a checkpoint directory (created if needed; existing files are replaced)."""
    path = Path(path)
    path.mkdir(parents=True, exist_ok=True)
    weights_sha = _write_tensors(path / MODEL_FILE, weights)
    if training is not None:
        optim_sha = _write_tensors(path / OPTIM_FILE, optimizer_tensors or {})
        _write_json(path / TRAINING_FILE, {**training, "optimizer_sha256": optim_sha, "weights_sha256": weights_sha})
    # config.json last: its checksum commits the weights written above.
    _write_json(path / CONFIG_FILE, {"format": FORMAT, "format_version": FORMAT_VERSION, **config, "weights_sha256": weights_sha})
    return path


def read_checkpoint(
    path: str | os.PathLike, *, training: bool = False
) -> tuple[dict[str, Any], dict[str, torch.Tensor], dict[str, Any] | None, dict[str, torch.Tensor] | None]:
    """Read a checkpoint directory.

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
    if not path.is_dir():
        raise CheckpointError(f"no checkpoint directory at {path}")
    config = _read_json(path / CONFIG_FILE)
    if config.get("format") != FORMAT:
        raise CheckpointError(f"{path} is not an {FORMAT} checkpoint (format={config.get('format')!r})")
    version = config_value(config, "format_version", int, path / CONFIG_FILE)
    if version > FORMAT_VERSION:
        raise CheckpointError(f"{path} has format version {version}; this version reads <= {FORMAT_VERSION}")
    weights = _read_tensors(path / MODEL_FILE, config.get("weights_sha256"), path / CONFIG_FILE)
    check_tensors(weights, path / MODEL_FILE)
    if not training:
        return config, weights, None, None
    state = _read_json(path / TRAINING_FILE)
    if state.get("weights_sha256") != config.get("weights_sha256"):
        raise CheckpointError(f"{path}: training state and weights come from different saves")
    optim = _read_tensors(path / OPTIM_FILE, state.get("optimizer_sha256"), path / TRAINING_FILE)
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
def read_run_state(run_dir: str | os.PathLike) -> dict[str, Any] | None:
    """The ``{"last": name, "best": name | None}`` pointers of a run, or None if new.

    Raises
    ------
    CheckpointError
        A pointer that is not the plain name of a checkpoint folder of the run (an absolute
        path, ``..``, a separator, a missing ``last``): loading never leaves the run folder.
    """
    path = Path(run_dir) / STATE_FILE
    if not path.exists():
        return None
    state = _read_json(path)
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
    old = read_run_state(run_dir) or {}
    # Fresh names: a referenced checkpoint is never rewritten in place.
    tag = f"{step:08d}-{uuid.uuid4().hex[:8]}"
    last = f"ckpt-{tag}"
    write_checkpoint(run_dir / last, config, weights, training=training, optimizer_tensors=optimizer_tensors)
    best = old.get("best")
    if best_is_current:
        best = last
    elif best_weights is not None:
        best = f"best-{tag}"
        write_checkpoint(run_dir / best, config, best_weights)
    _write_json(run_dir / STATE_FILE, {"last": last, "best": best})
    # Only now are older checkpoints unreferenced.
    for child in run_dir.iterdir():
        if child.is_dir() and child.name not in (last, best) and child.name.startswith(("ckpt-", "best-")):
            shutil.rmtree(child, ignore_errors=True)


#: Folder of the shipped releases: ``NAME.safetensors`` + ``NAME.json`` (a checkpoint's
#: two files under flat names).
PRETRAINED_DIR = Path(__file__).resolve().parents[1] / "pretrained"


def shipped_releases(class_name: str, directory: Path = PRETRAINED_DIR) -> list[str]:
    """Names of the complete releases in ``directory`` whose config records ``class_name``."""
    if not directory.is_dir():
        return []
    return sorted(p.stem for p in directory.glob("*.json") if p.with_suffix(".safetensors").is_file()
                  and json.loads(p.read_text()).get("class") == class_name)


def load_shipped(cls: type, name: Any, directory: Path = PRETRAINED_DIR) -> Any:
    """Release ``name`` of class ``cls`` (its ``load`` reads the release's two files).

    Raises
    ------
    KeyError
        No complete release of that class under ``name`` (the message lists them).
    """
    shipped = shipped_releases(cls.__name__, directory)
    if not isinstance(name, str) or name not in shipped:
        raise KeyError(f"no pretrained {cls.__name__} {name!r}; shipped: {shipped}")
    with release_folder(name, directory) as folder:
        return cls.load(folder)


#: The training drives of the releases shipped before their JSON recorded them (from their
#: model cards' training commands: v1-v3 and mixed-v1 the first 56 frames of 9001, v4 9001
#: and 9004). Every model saved since records ``training_drives`` itself.
SHIPPED_TRAINING_DRIVES: dict[str, list[str]] = {
    **{name: ["2011_09_26_drive_9001_sync"] for name in ("kitti-rect-v1", "kitti-rect-v2", "kitti-rect-v3",
                                                          "kitti-mixed-v1")},
    "kitti-rect-v4": ["2011_09_26_drive_9001_sync", "2011_09_26_drive_9004_sync"],
}


def provenance(est: Any) -> dict[str, Any]:
    """What a saved model records about its training data and machine: ``training_drives``
    (None when unknown) and ``environment`` (:func:`inpaintenv.environment.environment_info`
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
def release_folder(name: str, directory: Path = PRETRAINED_DIR) -> Iterator[Path]:
    """A temporary checkpoint folder holding release ``name``'s two files.

    The shipped pair is a checkpoint's files under flat names; copied (they are small)
    into one folder, they are read by the same checksum-verifying loader as any checkpoint.
    A release JSON without ``training_drives`` gets them from :data:`SHIPPED_TRAINING_DRIVES`.
    """
    with tempfile.TemporaryDirectory() as tmp:
        for suffix, target in ((".safetensors", MODEL_FILE), (".json", CONFIG_FILE)):
            shutil.copyfile(directory / f"{name}{suffix}", Path(tmp) / target)
        config = json.loads((Path(tmp) / CONFIG_FILE).read_text())
        if config.get("training_drives") is None and name in SHIPPED_TRAINING_DRIVES:
            config["training_drives"] = SHIPPED_TRAINING_DRIVES[name]
            (Path(tmp) / CONFIG_FILE).write_text(json.dumps(config))
        yield Path(tmp)


#: Neural estimator classes by the name a checkpoint's ``config.json`` records.
CLASSES: dict[str, type] = {}


def checkpoint_class(name: Any) -> type | None:
    """The estimator class a checkpoint names, or None if no such class is registered.

    Each learned family registers its classes in :data:`CLASSES` when its module is
    imported; :func:`estimators.learned.load.load_checkpoint` imports every family first,
    so this module never imports a family (or the package face) to find one.
    """
    return CLASSES.get(name) if isinstance(name, str) else None


def cpu_state(model: torch.nn.Module, clone: bool = False) -> dict[str, torch.Tensor]:
    """``model``'s state dict on the CPU, contiguous (``clone``: a copy training cannot change)."""
    state = {k: v.detach().to("cpu").contiguous() for k, v in model.state_dict().items()}
    return {k: v.clone() for k, v in state.items()} if clone else state


def progress_history(fitted: dict[str, Any]) -> dict[str, Any]:
    """History stored in a training-run checkpoint summary (or an empty one)."""
    return fitted.get("history") or {"step_loss": [], "epoch_loss": [], "val_hole_rmse": [], "best_epoch": None}


class CheckpointMixin:
    """``save`` and ``load`` of a neural inpainter: parameters and fitted state as JSON,
    weights as safetensors (the file format is above)."""

    def save(self, path: str | os.PathLike) -> Path:
        """Write the fitted model to the directory ``path`` (safetensors + JSON).

        Returns
        -------
        pathlib.Path
            The checkpoint directory; read it back with :meth:`load`.
        """
        if not hasattr(self, "model_"):
            from sklearn.exceptions import NotFittedError

            raise NotFittedError(f"this {type(self).__name__} is not fitted; nothing to save")
        # The config is written from the current parameters: they must still describe the weights.
        self._check_model_params()
        config = {
            "class": type(self).__name__,
            "params": self._config_params(),
            "seed": getattr(self, "seed_", None),
            "fitted": {"n_steps_": getattr(self, "n_steps_", 0), "history_": getattr(self, "history_", None)},
            **provenance(self),
        }
        return write_checkpoint(path, config, cpu_state(self.model_))

    @classmethod
    def load(cls, path: str | os.PathLike) -> Any:
        """Load a model written by :meth:`save`, or the best (else last) model of a run dir.

        Raises
        ------
        CheckpointError
            If the checkpoint is missing, truncated, corrupt, tampered with (see the module
            notes) or of another class.
        """
        path = Path(path)
        state = read_run_state(path) if path.is_dir() else None
        if state is not None:
            path = path / (state.get("best") or state["last"])
        config, weights, _, _ = read_checkpoint(path)
        return cls.from_config(config, weights, path)

    @classmethod
    def from_config(cls, config: dict[str, Any], weights: dict[str, torch.Tensor], where: Any) -> Any:
        """The model a checkpoint's ``config`` and (checked) ``weights`` describe, built in memory.

        ``where`` names the checkpoint in errors (a folder, or an ensemble's member).
        """
        klass = checkpoint_class(config.get("class"))
        if klass is None or not issubclass(klass, cls):
            raise CheckpointError(f"{where} holds a {config.get('class')!r}, not a {cls.__name__}")
        if klass is not cls:  # the recorded class's own reading (PriorUNetInpainter's tuples)
            return klass.from_config(config, weights, where)
        params = dict(config_value(config, "params", dict, where))
        if params.get("crop") is not None:
            params["crop"] = tuple(config_value(params, "crop", list, where))
        if isinstance(params.get("warm_start"), str) and params["warm_start"].startswith("<"):
            params["warm_start"] = None  # an in-memory estimator cannot be restored; weights are
        fitted = config_value(config, "fitted", dict, where, default={})
        n_steps = config_value(fitted, "n_steps_", int, where,
                               default=config_value(fitted, "step", int, where, default=0))
        history = config_value(fitted, "history_", dict, where, default=None)
        seed = config_value(config, "seed", int, where, default=None)
        est = build_checked(klass, params, where)
        est.model_ = load_weights(est._build_model(0), weights, where)
        est.history_ = history or progress_history(fitted)
        est.n_steps_ = n_steps
        est.seed_ = seed
        est.model_params_ = est._model_params()
        restore_provenance(est, config)
        est.is_fitted_ = True
        return est
