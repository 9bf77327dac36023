"""What a training state may be: the ``training.json`` of a run checkpoint and Adam's tensors
beside it, checked before a fit continues from them.

A training state says where a run stands (epoch, batch, step, finished), what it logged
(the history) and Adam's settings; with ``optimizer.safetensors`` it is all a fit resumes.
It lies in the run's own folder, but a file there can be edited, torn, or left by another
version or another run, and a fit would train on from it silently. So it is checked here,
in one place, and each failure is one :class:`CheckpointError` naming the file and what
disagrees:

- its form (:func:`check_form`, on every read): each key present with the type it is
  written with and no other, counts non-negative integers, losses finite and non-negative;
- its checksum: ``config.json``, written last, records the SHA-256 of ``training.json``
  as it records the weights' (checked by :func:`~._checkpoint.read_checkpoint`);
- itself and its checkpoint (:func:`check_progress`): one logged loss per step and per
  epoch, the position in the epoch adding up to the step, the step in the folder's name;
- the fit that resumes it (:class:`RunPlan`): the checkpoint's class, seed and parameters
  (:func:`check_config`), its epochs and ``max_steps`` (a finished run reached them, an
  unfinished one did not), and Adam (:func:`check_optimizer`): its own update count, its
  moments' shapes, its learning rate as the schedule gives it after that many updates,
  and every other setting as this fit builds it.

A checksum is no signature: someone who recomputes it can write a state that passes. What
remains checkable then is consistency, which is what the other checks are for.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import torch

from ._checkpoint_checks import CheckpointError

__all__ = ["RunPlan", "check_config", "check_fitted", "check_form", "check_optimizer", "check_progress",
           "checkpoint_step"]

#: The keys of a training state, with the type of each (``None``: may be null).
_REQUIRED: dict[str, tuple[type, ...]] = {
    "epoch": (int,), "batch": (int,), "step": (int,), "finished": (bool,), "history": (dict,), "optimizer": (dict,),
    "optimizer_sha256": (str,), "weights_sha256": (str,),
}
_OPTIONAL: dict[str, tuple[Any, ...]] = {"epoch_start_step": (int,), "rng": (dict, None), "global_rng": (dict, None)}
_HISTORY_LISTS = ("step_loss", "epoch_loss", "val_hole_rmse")
_HISTORY_KEYS = {*_HISTORY_LISTS, "best_epoch", "budget_stop"}
#: Adam's per-parameter state; ``max_exp_avg_sq`` with ``amsgrad`` only.
_MOMENTS = ("exp_avg", "exp_avg_sq")
#: A training checkpoint's folder name, as :func:`~._checkpoint.write_run_checkpoint` writes it.
_CHECKPOINT_NAME = re.compile(r"ckpt-(\d{8,})-[0-9a-f]{8}")
#: Config entries that may differ between a checkpoint and the fit that resumes it.
_CONFIG_FREE = {"params", "fitted", "torch_threads", "format", "format_version", "weights_sha256", "training_sha256"}


@dataclass(frozen=True)
class RunPlan:
    """What the fit that resumes a run expects of its training state.

    Parameters
    ----------
    epochs, steps_per_epoch : int
        The run's length.
    max_steps : int or None
        Where it stops earlier.
    updates_per_step : int
        The most optimiser updates one step takes.
    exact_updates : bool
        Every step takes exactly ``updates_per_step`` updates (no step without a loss, no
        update a gradient scaler skips): Adam's count must then equal it times the step.
    validates : bool
        Each epoch logs a validation RMSE.
    free_params : tuple of str
        Parameters that change nothing about the weights (threads, verbosity, folders):
        they may differ between the checkpoint and this fit.
    param_defaults : dict
        Parameters a checkpoint of an earlier version may lack, at the value it then had.
    """

    epochs: int
    steps_per_epoch: int
    max_steps: int | None
    updates_per_step: int = 1
    exact_updates: bool = True
    validates: bool = False
    free_params: tuple[str, ...] = ()
    param_defaults: dict[str, Any] = field(default_factory=dict)


def _shown(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _is(value: Any, kinds: tuple[Any, ...]) -> bool:
    """``value`` of one of ``kinds`` (``None`` in it: null), an int never a bool, a float also an int."""
    if value is None:
        return None in kinds
    if isinstance(value, bool):
        return bool in kinds
    types = tuple(k for k in kinds if k is not None)
    return isinstance(value, types) or (float in types and isinstance(value, int))


def _count(state: dict[str, Any], key: str, where: Any) -> None:
    if state[key] < 0:
        raise CheckpointError(f"{where}: {key!r} is {state[key]}; a count is never negative")


def _losses(values: Any, name: str, where: Any, nan: bool) -> None:
    """A list of numbers, each finite (or NaN where ``nan``) and non-negative."""
    if not isinstance(values, list):
        raise CheckpointError(f"{where}: history {name!r} must be a list of numbers, got {_shown(values)}")
    for i, v in enumerate(values):
        ok = _is(v, (float,)) and ((nan and math.isnan(v)) or (math.isfinite(v) and v >= 0))
        if not ok:
            raise CheckpointError(f"{where}: history {name!r}[{i}] is {_shown(v)}; it holds losses "
                                  f"(finite and not negative{', or NaN' if nan else ''})")


def check_form(state: Any, where: Any) -> dict[str, Any]:
    """``state`` if it has the form of a training state, else one :class:`CheckpointError`.

    Parameters
    ----------
    state : Any
        The parsed ``training.json``.
    where : path-like
        The file, for messages.
    """
    if not isinstance(state, dict):
        raise CheckpointError(f"{where} does not hold a training state (a JSON object)")
    unknown = sorted(set(state) - set(_REQUIRED) - set(_OPTIONAL))
    if unknown:
        raise CheckpointError(f"{where}: {unknown[0]!r} is not a key of a training state "
                              f"(keys: {', '.join(sorted({*_REQUIRED, *_OPTIONAL}))})")
    for key, kinds in (*_REQUIRED.items(), *_OPTIONAL.items()):
        if key not in state:
            if key in _REQUIRED:
                raise CheckpointError(f"{where}: the training state has no {key!r}")
            continue
        if not _is(state[key], kinds):
            names = " or ".join("null" if k is None else {int: "an integer", bool: "true or false", dict: "an object",
                                                           str: "a string"}[k] for k in kinds)
            raise CheckpointError(f"{where}: {key!r} must be {names}, got {_shown(state[key])}")
    for key in ("epoch", "batch", "step", "epoch_start_step"):
        if key in state:
            _count(state, key, where)
    history = state["history"]
    unknown = sorted(set(history) - _HISTORY_KEYS)
    if unknown:
        raise CheckpointError(f"{where}: history {unknown[0]!r} is not a record of training "
                              f"(records: {', '.join(sorted(_HISTORY_KEYS))})")
    for name in ("step_loss", "epoch_loss"):
        if name not in history:
            raise CheckpointError(f"{where}: the history has no {name!r}")
    for name in _HISTORY_LISTS:
        if name in history:
            _losses(history[name], name, where, nan=name != "step_loss")
    best = history.get("best_epoch")
    if best is not None and not (_is(best, (int,)) and best >= 0):
        raise CheckpointError(f"{where}: history 'best_epoch' must be an epoch (an integer from 0) or null, "
                              f"got {_shown(best)}")
    if not isinstance(history.get("budget_stop", {}), dict):
        raise CheckpointError(f"{where}: history 'budget_stop' must be an object, got {_shown(history['budget_stop'])}")
    meta = state["optimizer"]
    if set(meta) != {"param_groups", "scalars"}:
        raise CheckpointError(f"{where}: 'optimizer' must hold 'param_groups' and 'scalars' only, "
                              f"got {sorted(meta)}")
    groups = meta["param_groups"]
    if not isinstance(groups, list) or not groups or not all(isinstance(g, dict) for g in groups):
        raise CheckpointError(f"{where}: optimizer 'param_groups' must be a list of objects, got {_shown(groups)}")
    scalars = meta["scalars"]
    if not isinstance(scalars, dict) or not all(isinstance(v, dict) for v in scalars.values()):
        raise CheckpointError(f"{where}: optimizer 'scalars' must be an object of objects, got {_shown(scalars)}")
    return state


def checkpoint_step(name: str, where: Any) -> int:
    """The step a training checkpoint's folder ``name`` (``ckpt-<step>-<tag>``) records."""
    match = _CHECKPOINT_NAME.fullmatch(name)
    if match is None:
        raise CheckpointError(f"{where}: {name!r} is not the name of a training checkpoint (ckpt-<step>-<tag>), "
                              "which a run resumes from")
    return int(match.group(1))


def check_progress(state: dict[str, Any], plan: RunPlan, name: str, where: Any) -> None:
    """Refuse a (well-formed) training state that disagrees with itself, its folder's ``name`` or ``plan``.

    Raises
    ------
    CheckpointError
        Naming ``where`` and the disagreement.
    """
    step, epoch, batch, finished = state["step"], state["epoch"], state["batch"], state["finished"]
    history = state["history"]
    named = checkpoint_step(name, where)
    if named != step:
        raise CheckpointError(f"{where}: step {step} disagrees with its checkpoint folder {name} (step {named})")
    counts = {"step_loss": step, "epoch_loss": epoch, "val_hole_rmse": epoch if plan.validates else 0}
    for key, n in counts.items():
        logged = len(history.get(key, []))
        if logged != n:
            what = "step" if key == "step_loss" else "epoch" if plan.validates or key == "epoch_loss" else None
            expected = f"one per {what} ({n})" if what else "none (this run does not validate)"
            raise CheckpointError(f"{where}: history {key!r} has {logged} entries; it must have {expected}")
    best = history.get("best_epoch")
    if best is not None and (not plan.validates or best >= epoch):
        raise CheckpointError(f"{where}: history 'best_epoch' {best} is not a validated epoch of the "
                              f"{epoch} closed")
    if epoch > 0 and "epoch_start_step" not in state:
        raise CheckpointError(f"{where}: the training state has no 'epoch_start_step' after {epoch} epochs")
    start = state.get("epoch_start_step", 0)
    if start + batch != step:
        raise CheckpointError(f"{where}: step {step} is not the {start} steps of the closed epochs plus the "
                              f"{batch} batches of the current one")
    spe, total = plan.steps_per_epoch, plan.epochs * plan.steps_per_epoch
    limit = total if plan.max_steps is None else min(total, plan.max_steps)
    if step > limit:
        raise CheckpointError(f"{where}: step {step} is past this run's {limit} steps")
    if finished:
        # Finished by max_steps mid-epoch (that epoch closed early) or after the last full epoch.
        by_steps = plan.max_steps is not None and step == plan.max_steps and (epoch - 1) * spe < step <= epoch * spe
        by_epochs = epoch == plan.epochs and step == epoch * spe
        if batch != 0 or not (by_steps or by_epochs or (spe == 0 and epoch == 1)):
            raise CheckpointError(f"{where}: the state says finished at step {step}, epoch {epoch}, but this run "
                                  f"ends at max_steps={plan.max_steps} or after {plan.epochs} epochs")
    elif epoch >= plan.epochs or batch > spe or start != epoch * spe:
        raise CheckpointError(f"{where}: an unfinished state at epoch {epoch}, batch {batch} is not a position of "
                              f"this run ({plan.epochs} epochs of {spe} steps)")


def _json(value: Any) -> Any:
    """``value`` as written to JSON and read back (tuples as lists), for comparisons."""
    return json.loads(json.dumps(value))


_MISSING = object()


def check_config(saved: dict[str, Any], expected: dict[str, Any], plan: RunPlan, where: Any) -> None:
    """Refuse a checkpoint's config whose class, seed or weight-shaping parameters are not this fit's.

    The run folder's name is keyed by them, so a disagreement means the checkpoint was
    copied from another run (another preset, seed or process count) or edited.
    """
    for key in sorted((set(saved) | set(expected)) - _CONFIG_FREE):
        if _json(saved.get(key)) != _json(expected.get(key)):
            raise CheckpointError(f"{where}: the checkpoint's {key} is {_shown(saved.get(key))}, this run's is "
                                  f"{_shown(expected.get(key))}; it belongs to another run")
    mine, theirs = expected.get("params") or {}, saved.get("params")
    if not isinstance(theirs, dict):
        raise CheckpointError(f"{where}: config.json 'params' must be a JSON object, got {_shown(theirs)}")
    for key in sorted((set(mine) | set(theirs)) - set(plan.free_params)):
        a = theirs.get(key, plan.param_defaults.get(key, _MISSING))
        b = mine.get(key, _MISSING)
        if a is _MISSING or b is _MISSING or _json(a) != _json(b):
            shown = ["(none)" if v is _MISSING else _shown(v) for v in (a, b)]
            raise CheckpointError(f"{where}: the checkpoint was trained with {key}={shown[0]}, this run has "
                                  f"{key}={shown[1]}; it belongs to another run")


def check_fitted(config: dict[str, Any], state: dict[str, Any], where: Any) -> None:
    """Refuse a checkpoint whose ``config.json`` reports other steps or history than its training state."""
    fitted = config.get("fitted")
    if not isinstance(fitted, dict) or fitted.get("n_steps_") != state["step"] or \
            json.dumps(fitted.get("history_"), sort_keys=True) != json.dumps(state["history"], sort_keys=True):
        raise CheckpointError(f"{where}: config.json's 'fitted' (n_steps_, history_) is not the training state's "
                              "step and history")


def _parameters(optimizer: torch.optim.Optimizer) -> list[torch.Tensor]:
    return [p for group in optimizer.param_groups for p in group["params"]]


def _adam_state(tensors: dict[str, torch.Tensor], scalars: dict[str, dict[str, Any]], n: int, amsgrad: bool,
                where: Any) -> dict[int, dict[str, Any]]:
    """Adam's per-parameter state by index, from the tensor file and the JSON scalars, each name checked."""
    allowed = {"step", *_MOMENTS, *(("max_exp_avg_sq",) if amsgrad else ())}
    state: dict[int, dict[str, Any]] = {}
    items = [(name, value, where.with_name("optimizer.safetensors")) for name, value in tensors.items()]
    items += [(f"{pid}.{key}", value, where) for pid, extra in scalars.items() for key, value in extra.items()]
    for name, value, source in items:
        pid, sep, key = name.partition(".")
        if not sep or not pid.isascii() or not pid.isdecimal() or int(pid) >= n or key not in allowed:
            raise CheckpointError(f"{source}: {name!r} is not a state of Adam over this network's {n} parameters "
                                  f"(<index>.{'|'.join(sorted(allowed))})")
        if key in state.setdefault(int(pid), {}):
            raise CheckpointError(f"{source}: {name!r} is given twice")
        state[int(pid)][key] = value
    for pid, entry in state.items():
        missing = sorted(allowed - set(entry))
        if missing:
            raise CheckpointError(f"{where}: Adam's state of parameter {pid} has no {missing[0]!r}")
    return state


def _step_of(value: Any, pid: int, where: Any) -> int:
    number = float(value) if isinstance(value, torch.Tensor) and value.numel() == 1 and value.dim() == 0 else \
        value if _is(value, (float,)) else None
    if number is None or not math.isfinite(number) or number < 0 or number != int(number):
        raise CheckpointError(f"{where}: Adam's update count of parameter {pid} is {_shown(value)}; "
                              "it counts updates (a whole number from 0)")
    return int(number)


def check_optimizer(meta: dict[str, Any], tensors: dict[str, torch.Tensor], optimizer: torch.optim.Optimizer,
                    lr_after: Any, step: int, plan: RunPlan, where: Path) -> dict[str, Any]:
    """The ``state_dict`` to load into ``optimizer``, after checking the saved one against it.

    Parameters
    ----------
    meta, tensors
        The training state's ``optimizer`` entry and the tensors of ``optimizer.safetensors``.
    optimizer : torch.optim.Optimizer
        This fit's Adam, as built (from the estimator's parameters).
    lr_after : callable
        ``(lr, updates)`` -> the learning rates the schedule gives after ``updates`` updates
        (None: not checked).
    step : int
        The run's step (checked form and progress).
    where : Path
        ``training.json``.
    """
    fresh = optimizer.state_dict()
    groups = meta["param_groups"]
    if len(groups) != len(fresh["param_groups"]):
        raise CheckpointError(f"{where}: {len(groups)} optimizer parameter groups, this network has "
                              f"{len(fresh['param_groups'])}")
    params = _parameters(optimizer)
    amsgrad = any(bool(g.get("amsgrad")) for g in fresh["param_groups"])
    state = _adam_state(tensors, meta["scalars"], len(params), amsgrad, where)
    updates = 0
    for pid, entry in sorted(state.items()):
        shape = tuple(params[pid].shape)
        for key in entry:
            if key == "step":
                updates = max(updates, _step_of(entry[key], pid, where))
                continue
            value = entry[key]
            source = where.with_name("optimizer.safetensors")
            if not isinstance(value, torch.Tensor) or tuple(value.shape) != shape or not value.is_floating_point():
                raise CheckpointError(f"{source}: Adam's {key} of parameter {pid} must be a floating-point tensor "
                                      f"of the parameter's shape {shape}")
            if not bool(torch.isfinite(value).all()) or (key != "exp_avg" and bool((value < 0).any())):
                raise CheckpointError(f"{source}: Adam's {key} of parameter {pid} holds "
                                      f"{'NaN or inf' if not bool(torch.isfinite(value).all()) else 'negative'} values")
    most = step * plan.updates_per_step
    if updates > most or (plan.exact_updates and updates != most):
        raise CheckpointError(f"{where}: Adam counts {updates} updates, which {step} steps of "
                              f"{plan.updates_per_step} update{'s' * (plan.updates_per_step != 1)} "
                              f"{'cannot give' if updates > most else 'do not give'}")
    for i, (saved, built) in enumerate(zip(groups, fresh["param_groups"])):
        if set(saved) != set(built):
            odd = sorted(set(saved) ^ set(built))[0]
            raise CheckpointError(f"{where}: optimizer group {i} {'has' if odd in saved else 'lacks'} {odd!r}, "
                                  "which Adam as this run builds it does not have (another torch version or an edit)")
        for key in sorted(set(built) - {"lr"}):
            if _json(saved[key]) != _json(built[key]):
                raise CheckpointError(f"{where}: optimizer {key}={_shown(saved[key])} disagrees with this run's "
                                      f"{key}={_shown(built[key])}")
        expected = lr_after(built["lr"], updates)
        lr = saved["lr"]
        if expected is not None and not (_is(lr, (float,)) and any(
                math.isclose(lr, e, rel_tol=1e-6, abs_tol=0.0) for e in expected)):
            raise CheckpointError(f"{where}: optimizer lr={_shown(lr)} disagrees with this run's lr and schedule, "
                                  f"which give {' or '.join(f'{e:.6g}' for e in expected)} after {updates} updates")
    return {"state": state, "param_groups": groups}
