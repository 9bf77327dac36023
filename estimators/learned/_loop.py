"""The one fitting loop of every learned family: optimiser, schedule, seeding, divergence
check, progress, time budget, checkpoints and resume, and the split over processes.

A family says only what is its own: how an epoch's batches are drawn and what one step
does with a batch (its loss, through :meth:`Optimisation.update`); :func:`fit_loop` does
the rest the same way for all. The U-Net, the autoencoder and the PriorUNet step over
frames (:class:`~estimators.learned._training.TrainingMixin`); the blends, the scan blend
and the context blend step over pooled pixels or samples (``_fit_pixels``, through
:func:`~._pixel_model.fit_rows`, / ``_train_network``). Every run is seeded from its ``seed`` alone (:func:`seeded`), and
on the CPU its kernels are deterministic (``deterministic_torch`` in ``._training``).
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
import torch

from inpaintenv.exceptions import RunLockedError, TrainingDivergedError
from inpaintenv.files.lock import run_lock
from inpaintenv.progress import format_duration, stderr_is_terminal

from . import _checkpoint as ckpt
from ._budget import Budget, StepBar, record_stop
from ._checkpoint import cpu_state
from ._training_state import RunPlan, check_config, check_fitted, check_optimizer, check_progress, checkpoint_step

__all__ = [
    "Constant", "Cosine", "OneCycle", "Optimisation", "RunFolder", "RunPlan", "Schedule", "Shard", "fit_loop",
    "new_progress", "seeded",
]

Model = TypeVar("Model", bound=torch.nn.Module)


def seeded(build: Callable[[], Model], seed: int) -> Model:
    """``build()`` with torch's generator seeded by ``seed``, the caller's global stream untouched."""
    with torch.random.fork_rng(devices=[]):
        torch.manual_seed(seed)
        return build()


class Schedule:
    """The learning rate of each update; :class:`Constant` keeps Adam's own."""

    def bind(self, optimizer: torch.optim.Optimizer) -> None:
        """Attach to ``optimizer`` (once, before the first update)."""

    def before(self, optimizer: torch.optim.Optimizer) -> None:
        """Set the learning rate of the coming update."""

    def after(self) -> None:
        """Advance after an update."""

    def lr_after(self, lr: float, updates: int) -> tuple[float, ...] | None:
        """The learning rates an optimiser built with ``lr`` may hold after ``updates`` updates
        (what a resumed state must agree with); None where the schedule cannot say."""
        return None


class Constant(Schedule):
    """The optimiser's learning rate throughout."""

    def lr_after(self, lr: float, updates: int) -> tuple[float, ...]:
        return (float(lr),)


class OneCycle(Schedule):
    """torch's one-cycle schedule (``OneCycleLR``) over ``total`` updates, stepped after each."""

    def __init__(self, lr: float, total: int, pct_start: float = 0.05):
        self.lr, self.total, self.pct_start = float(lr), int(total), float(pct_start)
        self._torch: Any = None

    def bind(self, optimizer: torch.optim.Optimizer) -> None:
        self._torch = torch.optim.lr_scheduler.OneCycleLR(optimizer, max_lr=self.lr, total_steps=self.total,
                                                          pct_start=self.pct_start)

    def after(self) -> None:
        self._torch.step()


class Cosine(Schedule):
    """Cosine decay over ``total`` updates after a linear warm-up of 5 %, never below 1 % of ``lr``.

    The update count is read from Adam's own state, so a resumed run continues the schedule.
    """

    def __init__(self, lr: float, total: int):
        self.lr, self.total = float(lr), int(total)

    def before(self, optimizer: torch.optim.Optimizer) -> None:
        state = optimizer.state.get(optimizer.param_groups[0]["params"][0], {})
        lr = self._lr_at(float(state.get("step", 0)))
        for group in optimizer.param_groups:
            group["lr"] = lr

    def _lr_at(self, step: float) -> float:
        """The learning rate of the update after ``step`` updates."""
        warm = max(1.0, 0.05 * self.total)
        scale = (step + 1) / warm if step < warm else \
            0.5 * (1 + np.cos(np.pi * min(1.0, (step - warm) / max(1.0, self.total - warm))))
        return self.lr * max(scale, 0.01)

    def lr_after(self, lr: float, updates: int) -> tuple[float, ...]:
        # The rate set before the last update; an update a gradient scaler skipped leaves
        # Adam's count behind the rate set for it.
        return (float(lr),) if updates == 0 else (self._lr_at(updates - 1), self._lr_at(updates))


class Optimisation:
    """Adam, its schedule, mixed precision and the divergence check: one optimiser update.

    Parameters
    ----------
    model : torch.nn.Module
        The parameters to fit.
    lr, weight_decay : float
        Adam's.
    schedule : Schedule, optional
        Learning rate per update (default :class:`Constant`).
    autocast : context manager, optional
        The forward pass's precision (what ``update``'s loss function enters).
    scaler : torch.amp.GradScaler, optional
        fp16 gradient scaling on CUDA.
    """

    def __init__(self, model: torch.nn.Module, lr: float, weight_decay: float = 0.0, schedule: Schedule | None = None,
                 autocast: Any = None, scaler: Any = None):
        self.optimizer = torch.optim.Adam(model.parameters(), lr=float(lr), weight_decay=float(weight_decay))
        self.schedule = schedule or Constant()
        self.schedule.bind(self.optimizer)
        self.autocast = autocast if autocast is not None else contextlib.nullcontext()
        self.scaler = scaler
        self.updates = 0

    def update(self, loss_of: Callable[[], torch.Tensor]) -> float:
        """One update on the loss ``loss_of()`` returns; that loss, as a float.

        Raises
        ------
        TrainingDivergedError
            (a ``FloatingPointError``) If the loss is NaN or infinite; the update is not taken.
        """
        self.schedule.before(self.optimizer)
        self.optimizer.zero_grad(set_to_none=True)
        loss = loss_of()
        if not torch.isfinite(loss):
            hint = "lower lr or disable amp" if self.scaler is not None or \
                not isinstance(self.autocast, contextlib.nullcontext) else "lower lr"
            raise TrainingDivergedError(f"training loss became {loss.item()} at update {self.updates + 1}; {hint}")
        if self.scaler is not None:
            self.scaler.scale(loss).backward()
            self.scaler.step(self.optimizer)
            self.scaler.update()
        else:
            loss.backward()
            self.optimizer.step()
        self.schedule.after()
        self.updates += 1
        return float(loss.detach())


class Shard:
    """How one process takes part in a run: here, alone (the whole batch).

    :func:`fit_loop` asks it for the loss to log, whether to stop on the time budget and
    whether to write; the frame-stepping families also ask it for the frames to visit and
    the model to step. ``estimators.learned.distributed`` passes a subclass that splits each
    global batch over the processes of a job and wraps the model in
    ``DistributedDataParallel`` (as torchvision's reference scripts swap the sampler and wrap
    the model around one loop).
    """

    #: This process writes the checkpoints and shows the progress bar.
    writes: bool = True
    #: Prefix of the run folder's name: a run's progress is only resumed by the same split.
    run_prefix: str = ""
    #: Extra entries of the checkpoint's config.
    config: dict[str, Any] = {}

    def check_data(self, n_frames: int, batch_size: int) -> None:
        """Raise ValueError if ``n_frames`` training frames cannot be split as this shard needs."""

    def batches_per_epoch(self, n_frames: int, batch_size: int) -> int:
        """Optimiser steps in one full epoch."""
        return math.ceil(n_frames / batch_size)

    def local_batch(self, batch_size: int) -> int:
        """Frames this process loads per step."""
        return batch_size

    def order(self, order: np.ndarray, batch_size: int) -> np.ndarray:
        """The frames this process visits, in step order, out of an epoch's ``order``."""
        return order

    def wrap(self, model: torch.nn.Module, device: torch.device) -> torch.nn.Module:
        """The module the training steps call (its parameters are ``model``'s)."""
        return model

    def mean_loss(self, loss: float, device: torch.device) -> float:
        """The loss of the whole step (the mean over the processes)."""
        return loss

    def saved(self, run_dir: Path, step: int) -> None:
        """Called after each checkpoint this process wrote."""

    def done(self, progress: dict[str, Any]) -> None:
        """Called once the last step is taken."""

    def agree_stop(self, stop: bool, device: torch.device) -> bool:
        """Whether the run stops on its time budget now (all processes of a job must agree)."""
        return stop


def new_progress(**history: Any) -> dict[str, Any]:
    """Where a fresh run stands: no epoch, batch or step done; ``history`` adds entries to its history."""
    return {"epoch": 0, "batch": 0, "step": 0, "finished": False,
            "history": {"step_loss": [], "epoch_loss": [], **history}}


class RunFolder:
    """A run's checkpoints in ``path``: what :func:`fit_loop` writes and a fit resumes from.

    Parameters
    ----------
    path : Path
        The run folder (owned by the fit: read without following links).
    config : dict
        The checkpoint's config (class, parameters, seed).
    shard : Shard
        Only a writing shard writes.
    """

    def __init__(self, path: Path, config: dict[str, Any], shard: Shard):
        self.path, self.config, self.shard = path, config, shard

    @contextlib.contextmanager
    def held(self) -> Iterator[None]:
        """Hold the run folder's lock (``run.lock``) for the block, if this process writes.

        Raises
        ------
        RunLockedError
            Another live process trains in this run folder (it is named).
        CheckpointError
            The run folder is a symbolic link.
        """
        if not self.shard.writes:  # the other processes of a job: rank 0 holds it for them
            yield
            return
        ckpt.check_not_linked(self.path)
        try:
            with run_lock(self.path):
                yield
        except RunLockedError as e:
            if "in use by another run" not in str(e):
                raise
            raise RunLockedError(str(e).replace("choose another --out", "use another checkpoint_dir")) from None

    def resume(self, model: torch.nn.Module, optimisation: Optimisation,
               plan: RunPlan) -> tuple[dict, dict | None] | None:
        """Load the last checkpoint's weights and optimiser state; its progress and the best weights (None: a fresh run).

        Parameters
        ----------
        model, optimisation
            This fit's network and its optimiser, as built from the estimator's parameters.
        plan : RunPlan
            What this fit expects of the run (its length, Adam's updates per step, ...).

        Raises
        ------
        CheckpointError
            The last checkpoint is torn, edited, or disagrees with itself, its folder's name
            or this fit (:mod:`~estimators.learned._training_state`); one line naming the file.
        """
        state = ckpt.read_run_state(self.path, owned=True)
        if state is None:
            return None
        folder = self.path / state["last"]
        checkpoint_step(state["last"], self.path / ckpt.STATE_FILE)  # a training checkpoint, not a best one
        config, weights, progress, optim = ckpt.read_checkpoint(folder, training=True, owned=True)
        where = folder / ckpt.TRAINING_FILE
        check_config(config, self.config, plan, folder / ckpt.CONFIG_FILE)
        check_progress(progress, plan, state["last"], where)
        check_fitted(config, progress, folder / ckpt.CONFIG_FILE)
        optimizer = optimisation.optimizer
        adam = check_optimizer(progress.pop("optimizer"), optim, optimizer, optimisation.schedule.lr_after,
                               progress["step"], plan, where)
        ckpt.load_weights(model, weights, folder / ckpt.MODEL_FILE).train()
        optimizer.load_state_dict(adam)
        for k in ("optimizer_sha256", "weights_sha256"):
            progress.pop(k, None)
        best = None
        if state.get("best"):
            _, best, _, _ = ckpt.read_checkpoint(self.path / state["best"], owned=True)
        return progress, best

    def write(self, progress: dict[str, Any], model: torch.nn.Module, optimizer: torch.optim.Optimizer,
             rngs: dict[str, Any], *, new_best: bool = False) -> None:
        """Write a checkpoint of where ``progress`` stands (``rngs``: the random streams to continue)."""
        if not self.shard.writes:
            return
        tensors, meta = ckpt.flatten_optimizer_state(optimizer.state_dict())
        fitted = {"n_steps_": progress["step"], "history_": progress["history"]}
        ckpt.write_run_checkpoint(self.path, progress["step"], {**self.config, "fitted": fitted}, cpu_state(model),
                                  {**progress, "optimizer": meta, **rngs}, tensors, best_is_current=new_best)
        self.shard.saved(self.path, progress["step"])


def fit_loop(
    progress: dict[str, Any],
    epoch_batches: Callable[[int, int], Iterable[Any]],
    step: Callable[[Any], float],
    *,
    epochs: int,
    steps_per_epoch: int,
    max_steps: int | None = None,
    desc: str,
    verbose: bool = False,
    max_minutes: float | None = None,
    shard: Shard | None = None,
    device: torch.device | None = None,
    end_epoch: Callable[[dict[str, Any]], bool] | None = None,
    checkpoint: Callable[..., None] | None = None,
    checkpoint_every: int | None = None,
) -> dict[str, Any]:
    """Take the steps of a run from where ``progress`` stands until it is finished or its time is spent.

    Parameters
    ----------
    progress : dict
        :func:`new_progress`, or a resumed run's; updated in place and returned.
    epoch_batches : callable
        ``(epoch, batches_done)`` -> the batches left of that epoch, in step order (drawn
        lazily: a batch's random draws come after the previous step's).
    step : callable
        One step on a batch (one or more :meth:`Optimisation.update`); its loss.
    epochs, steps_per_epoch : int
        The run's length; ``max_steps`` stops it earlier (mid-epoch).
    desc, verbose : str, bool
        The progress bar's name, and whether it is shown.
    max_minutes : float, optional
        The time budget of this call, checked after every step; a run it stops is saved and
        its history records the stop (fit again resumes it).
    shard, device
        This process's part of a multi-process run (default: alone).
    end_epoch : callable, optional
        Called at each epoch's end (validation); returns whether the weights are the best so far.
    checkpoint : callable, optional
        ``checkpoint(new_best=...)`` writes a checkpoint: after every epoch, every
        ``checkpoint_every`` steps and at a budget stop.
    """
    shard = shard or Shard()
    budget = Budget(max_minutes)
    # As scikit-learn's verbose: on a terminal a bar; in a log (stderr a file or pipe) one line per epoch.
    shown = bool(verbose) and shard.writes
    lines = shown and not stderr_is_terminal()
    bar = StepBar(epochs * steps_per_epoch if max_steps is None else min(max_steps, epochs * steps_per_epoch),
                  progress["step"], budget, disable=not shown or lines, desc=desc)
    progress["history"].pop("budget_stop", None)  # a resumed run records its own stop
    write = checkpoint or (lambda **_: None)
    running: float | None = None
    try:
        while not progress["finished"]:
            stopped = None
            epoch = progress["epoch"]
            for batch in epoch_batches(epoch, progress["batch"]):
                loss = shard.mean_loss(step(batch), device)
                progress["history"]["step_loss"].append(loss)
                progress["step"] += 1
                progress["batch"] += 1
                running = loss if running is None else 0.9 * running + 0.1 * loss
                bar.update(1)
                bar.set_postfix(loss=f"{running:.4f}", epoch=epoch)
                if max_steps is not None and progress["step"] >= max_steps:
                    stopped = "steps"
                    break
                if budget.minutes is not None and shard.agree_stop(budget.spent(), device):
                    stopped = "budget"
                    break
                if checkpoint_every and progress["step"] % checkpoint_every == 0:
                    write()
            if stopped == "budget":
                # Mid-epoch, as a checkpoint_every save: fit again resumes from this step.
                record_stop(progress, budget, desc, verbose and shard.writes)
                write()
                break
            new_best = _close_epoch(progress, end_epoch)
            progress["finished"] = stopped == "steps" or progress["epoch"] >= epochs or steps_per_epoch == 0
            if lines:
                _epoch_line(desc, progress, epochs, bar)
            write(new_best=new_best)
    finally:
        bar.close()
    shard.done(progress)
    return progress


def _epoch_line(desc: str, progress: dict[str, Any], epochs: int, bar: StepBar) -> None:
    """One line in a log after an epoch: which, the steps done of all, its mean loss, the time left."""
    import sys

    loss = progress["history"]["epoch_loss"][-1]
    seconds = bar.time_left.seconds()
    left = "time left not measured yet" if seconds is None else f"{format_duration(seconds)} left"
    print(f"{desc}: epoch {progress['epoch']}/{epochs}, step {progress['step']}/{bar.time_left.total}, "
          f"loss {loss:.4f}, {left}", file=sys.stderr, flush=True)


def _close_epoch(progress: dict[str, Any], end_epoch: Callable[[dict[str, Any]], bool] | None) -> bool:
    """Record an epoch's (or a run stopped mid-epoch's) mean loss, call ``end_epoch`` and move to the next."""
    hist = progress["history"]
    done_steps = hist["step_loss"][progress.get("epoch_start_step", 0):]
    hist["epoch_loss"].append(float(np.mean(done_steps)) if done_steps else float("nan"))
    new_best = bool(end_epoch(progress)) if end_epoch is not None else False
    progress["epoch"] += 1
    progress["batch"] = 0
    progress["epoch_start_step"] = progress["step"]
    return new_best
