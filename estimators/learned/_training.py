"""Training of the neural inpainters: the loop, its resume state and its threads (samples:
:mod:`._training_data`; their loader and the device path: :mod:`._sampling`).

Reproducibility: every random choice of a training sample (crop offset, occlusion mask,
flip, depth factor) comes from generators seeded by ``(seed, epoch, index)`` alone, and the
visiting order of an epoch from ``(seed, epoch)``. A sample therefore does not depend on
which worker loads it, on the device that assembles it or on whether training was
interrupted, and resuming mid-epoch only needs the epoch and the number of batches done.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import torch

from inpaintenv.conventions import check_depth
from inpaintenv.data.base import DepthDataset, split_by_drive
from inpaintenv.report.provenance import environment_info
from inpaintenv.exceptions import InvalidInputError, InvalidTypeError, TrainingDivergedError
from inpaintenv.masks import OcclusionProtocol, get_protocol
from inpaintenv.metrics import aggregate, frame_metrics

from ..base import resolve_seed
from . import _checkpoint as ckpt
from ._budget import Budget, StepBar, record_stop
from ._limits import usable_threads
from ._checkpoint import cpu_state
from .losses import inpainting_loss
from ._random_state import global_rng_state, set_global_rng_state
from ._sampling import TrainingBatches
from ._training_data import (  # noqa: F401  (re-exported: the loop's data side)
    Augmentation, OcclusionFrames, crop_shape, data_fingerprint, encode_input, epoch_order, frame_label, make_loader,
    sample_rng,
)
from .nets import UNet

__all__ = [
    "OcclusionFrames",
    "Shard",
    "TrainingMixin",
    "crop_shape",
    "data_fingerprint",
    "encode_input",
    "epoch_order",
    "frame_label",
    "global_rng_state",
    "make_loader",
    "deterministic_torch",
    "sample_rng",
    "set_global_rng_state",
    "torch_threads",
]

@contextlib.contextmanager
def torch_threads(n: int | None) -> Iterator[int]:
    """Set ``torch.set_num_threads(n)`` for the block and restore it after.

    ``None`` keeps the current setting (which under joblib's loky workers already is
    ``cores // n_jobs``, since loky exports ``OMP_NUM_THREADS`` to its workers). More
    threads than the machine has cores are never started: ``n`` is capped at
    ``os.cpu_count()`` (:func:`~estimators.learned._limits.usable_threads`).
    """
    before = torch.get_num_threads()
    if n is not None:
        torch.set_num_threads(usable_threads(n))
    try:
        yield torch.get_num_threads()
    finally:
        if n is not None:
            torch.set_num_threads(before)


@contextlib.contextmanager
def deterministic_torch(enabled: bool = True) -> Iterator[None]:
    """``torch.use_deterministic_algorithms(True)`` for the block, restored after.

    Training on the CPU sets it: torch then uses a deterministic kernel wherever it has
    one and warns where it has none (``warn_only``), so two identical runs on one machine
    give identical weights. It cannot make other machines agree: a different CPU
    instruction set or library version sums floats in another order.
    """
    if not enabled:
        yield
        return
    before = torch.are_deterministic_algorithms_enabled()
    warn_before = torch.is_deterministic_algorithms_warn_only_enabled()
    torch.use_deterministic_algorithms(True, warn_only=True)
    try:
        yield
    finally:
        torch.use_deterministic_algorithms(before, warn_only=warn_before)


class Shard:
    """How one process takes part in a training run: here, alone (the whole batch).

    The loop of :class:`TrainingMixin` asks it for the frames to visit, the batch to load,
    the loss to log and the model to step; ``estimators.learned.distributed`` passes a
    subclass that splits each global batch over the processes of a job and wraps the
    model in ``DistributedDataParallel`` (as torchvision's reference scripts swap the
    sampler and wrap the model around one loop).
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


#: Parameters that change nothing about the trained weights: left out of the run-directory
#: hash so that e.g. changing ``verbose`` still resumes the same run (and a run stopped by
#: its ``max_minutes`` continues when fit is called again).
_RUN_INDEPENDENT = ("verbose", "num_workers", "num_threads", "checkpoint_dir", "checkpoint_every", "keep_observed",
                    "max_minutes", "sample_device")


def backward_step(loss: torch.Tensor, optimizer: torch.optim.Optimizer, scaler: Any) -> float:
    """Back-propagate ``loss`` and step ``optimizer`` (through the AMP ``scaler`` if any).

    Raises
    ------
    FloatingPointError
        If the loss is NaN or infinite (the step is not taken).
    """
    if not torch.isfinite(loss):
        raise TrainingDivergedError(f"training loss became {loss.item()} at step; lower lr or disable amp")
    if scaler is not None:
        scaler.scale(loss).backward()
        scaler.step(optimizer)
        scaler.update()
    else:
        loss.backward()
        optimizer.step()
    return float(loss.detach())


class TrainingMixin:
    """The training loop of a neural inpainter: run directory, resume, warm start, the
    optimiser steps and per-epoch validation (``fit`` of :class:`estimators.learned._neural._NeuralInpainter`).

    Relies on the parameter mixin (``_check_params``, ``_device``, ``_build_model``, ...)
    and the checkpoint mixin of the same class.
    """

    def _run_dir(self, dataset: DepthDataset, seed: int) -> Path | None:
        if self.checkpoint_dir is None:
            return None
        params = {k: v for k, v in self._config_params().items() if k not in _RUN_INDEPENDENT
                  and not (k in self._run_key_defaults and v == self._run_key_defaults[k])}
        key = json.dumps({"params": params, "seed": seed, "data": data_fingerprint(dataset)}, sort_keys=True)
        digest = hashlib.sha256(key.encode()).hexdigest()[:16]
        return Path(self.checkpoint_dir) / f"{type(self).__name__}-{digest}"

    def _fit(self, dataset: DepthDataset) -> None:
        self._check_fit(dataset)
        self._fit_on(dataset, resolve_seed(self.random_state), self._device())

    def _check_fit(self, dataset: DepthDataset) -> None:
        """Refuse bad parameters, too large a network and frames it cannot train on, before any work."""
        self._check_params()
        self._check_size()
        check_depth(dataset[0], name="X[0]")
        self._check_frame_size(dataset.frame_shape)

    def _fit_on(self, dataset: DepthDataset, seed: int, device: torch.device, shard: Shard | None = None) -> None:
        """Train on ``device`` with ``seed`` (one process of a distributed job when ``shard`` says so)."""
        with torch_threads(self.num_threads) as n_threads, deterministic_torch(torch.device(device).type == "cpu"):
            self.n_threads_ = n_threads
            self.fit_environment_ = environment_info(torch_details=True)
            self._train(dataset, seed, device, shard)
        self.seed_ = seed
        self.model_params_ = self._model_params()

    def _train(self, dataset: DepthDataset, seed: int, device: torch.device, shard: Shard | None = None) -> None:
        """Fit ``self.model_`` step by step, resuming from and writing checkpoints in the run folder.

        ``shard`` splits each global batch over the processes of a distributed job
        (``estimators.learned.distributed``); None trains in this process alone.
        """
        shard = shard or Shard()
        if self.validation_fraction is not None:
            train_ds, val_ds = split_by_drive(dataset, self.validation_fraction, seed=seed)
        else:
            train_ds, val_ds = dataset, None
        shard.check_data(len(train_ds), self.batch_size)
        protocol = get_protocol(self.protocol)
        model = self._initial_model(seed)
        optimizer, autocast, scaler = self._prepare_training(model, device)

        n_batches = shard.batches_per_epoch(len(train_ds), self.batch_size)
        total = self.epochs * n_batches if self.max_steps is None else min(self.max_steps, self.epochs * n_batches)
        progress: dict[str, Any] = {
            "epoch": 0, "batch": 0, "step": 0, "finished": False,
            "history": {"step_loss": [], "epoch_loss": [], "val_hole_rmse": [], "best_epoch": None},
        }
        best_state: dict[str, torch.Tensor] | None = None
        run_dir = self._run_dir(dataset, seed)
        if run_dir is not None:
            run_dir = run_dir.with_name(shard.run_prefix + run_dir.name)
        self.run_dir_ = run_dir
        config = {"class": type(self).__name__, "params": self._config_params(), "seed": seed,
                  "torch_threads": torch.get_num_threads(), **shard.config}
        if run_dir is not None:
            resumed = self._resume(run_dir, model, optimizer, device)
            if resumed is not None:
                progress, best_state = resumed
                self._set_rng_state(progress.pop("rng", None))
                set_global_rng_state(progress.pop("global_rng", None))
        # Wrapped after the resume: DDP broadcasts the (resumed) weights of rank 0.
        step_model = self._compiled(shard.wrap(model, device))
        data = OcclusionFrames(train_ds, protocol, self.crop, seed, self._augmentation())
        batches = TrainingBatches(data, shard.local_batch(self.batch_size), self.num_workers, device,
                                  self._sample_on_device(device))

        def save(*, new_best: bool = False) -> None:
            if run_dir is None or not shard.writes:
                return
            tensors, meta = ckpt.flatten_optimizer_state(optimizer.state_dict())
            rngs = {"rng": self._rng_state(), "global_rng": global_rng_state()}
            ckpt.write_run_checkpoint(
                run_dir, progress["step"], {**config, "fitted": _fitted_summary(progress)},
                cpu_state(model), {**progress, "optimizer": meta, **rngs}, tensors,
                best_is_current=new_best,
            )
            shard.saved(run_dir, progress["step"])

        running = None
        budget = Budget(getattr(self, "max_minutes", None))
        bar = StepBar(total, progress["step"], budget, disable=not (self.verbose and shard.writes),
                      desc=type(self).__name__)
        progress["history"].pop("budget_stop", None)  # a resumed run records its own stop
        try:
            while not progress["finished"]:
                stopped, running = self._train_epoch(
                    model, step_model, optimizer, scaler, autocast, batches, progress, seed, device, bar, running, save,
                    shard, budget,
                )
                if stopped == "budget":
                    # Mid-epoch, as a checkpoint_every save: fit again resumes from this step.
                    record_stop(progress, budget, type(self).__name__, self.verbose and shard.writes)
                    save()
                    break
                best_state, new_best = self._end_epoch(model, progress, val_ds, protocol, seed, device, best_state)
                progress["finished"] = stopped == "steps" or progress["epoch"] >= self.epochs or n_batches == 0
                save(new_best=new_best)
        finally:
            bar.close()
            batches.close()
        shard.done(progress)

        if best_state is not None:
            model.load_state_dict(best_state)
        self.model_ = model.to("cpu", memory_format=torch.contiguous_format).eval()
        self.history_ = progress["history"]
        self.n_steps_ = progress["step"]

    def _rng_state(self) -> dict[str, Any] | None:
        """As JSON, the state of a random stream that advances step by step (the PriorUNet's
        flips), so a resume continues it; None: samples depend on ``(seed, epoch, index)`` only."""
        return None

    def _set_rng_state(self, state: dict[str, Any] | None) -> None:
        """Restore what :meth:`_rng_state` returned (None: a checkpoint that recorded none)."""

    #: Parameters left out of the run folder's key at these values (added after run folders
    #: were written, so those still resume).
    _run_key_defaults: dict[str, Any] = {}

    def _augmentation(self) -> Augmentation | None:
        """Flips and depth factors of the training samples (None: crops and occlusions only)."""
        return None

    def _sample_on_device(self, device: torch.device) -> bool:
        """Whether batches are cropped and occluded on ``device`` (:mod:`._sampling`)."""
        return False

    def _initial_model(self, seed: int) -> torch.nn.Module:
        """A new network, its encoder (or all of it, for ``warm_start=True``) copied from the warm start."""
        model = self._build_model(seed)
        if self.warm_start is True:
            # scikit-learn's meaning: continue from this estimator's previous fit, if any.
            if hasattr(self, "model_"):
                _copy_encoder(self.model_, model)
                model.load_state_dict(self.model_.state_dict())
        elif self.warm_start is not None and self.warm_start is not False:
            _copy_encoder(self._warm_start_model(), model)
        return model

    def _train_epoch(
        self, model: torch.nn.Module, step_model: torch.nn.Module, optimizer: Any, scaler: Any, autocast: Any,
        batches: TrainingBatches,
        progress: dict[str, Any], seed: int, device: torch.device, bar: Any, running: float | None, save: Any,
        shard: Shard, budget: Budget | None = None,
    ) -> tuple[str | None, float | None]:
        """The optimiser steps of the current epoch from where ``progress`` stands; returns
        what stopped it early (``"steps"``: ``max_steps``; ``"budget"``: ``max_minutes``,
        checked after every step; None: the epoch ended) and the running loss on the bar."""
        epoch = progress["epoch"]
        batch = shard.local_batch(self.batch_size)
        order = shard.order(epoch_order(len(batches.data), seed, epoch), self.batch_size)[progress["batch"] * batch:]
        step_model.train()
        for gt, hole in batches.epoch(epoch, order):
            loss = shard.mean_loss(self._train_step(step_model, optimizer, scaler, autocast, gt, hole, device), device)
            progress["history"]["step_loss"].append(loss)
            progress["step"] += 1
            progress["batch"] += 1
            running = loss if running is None else 0.9 * running + 0.1 * loss
            bar.update(1)
            bar.set_postfix(loss=f"{running:.4f}", epoch=epoch)
            if self.max_steps is not None and progress["step"] >= self.max_steps:
                return "steps", running
            if budget is not None and budget.minutes is not None and shard.agree_stop(budget.spent(), device):
                return "budget", running
            if self.checkpoint_every and progress["step"] % self.checkpoint_every == 0:
                save()
        return None, running

    def _end_epoch(
        self, model: torch.nn.Module, progress: dict[str, Any], val_ds: DepthDataset | None,
        protocol: OcclusionProtocol, seed: int, device: torch.device, best_state: dict[str, torch.Tensor] | None,
    ) -> tuple[dict[str, torch.Tensor] | None, bool]:
        """Close an epoch (or a run stopped by ``max_steps`` mid-epoch): its mean loss, the
        validation RMSE and the best weights so far; returns them and whether they are new."""
        hist = progress["history"]
        start = sum(1 for _ in hist["epoch_loss"])
        done_steps = hist["step_loss"][progress.get("epoch_start_step", 0):]
        hist["epoch_loss"].append(float(np.mean(done_steps)) if done_steps else float("nan"))
        new_best = False
        if val_ds is not None:
            rmse = self._validation_rmse(model, val_ds, protocol, seed, device)
            hist["val_hole_rmse"].append(rmse)
            prev = [v for v in hist["val_hole_rmse"][:-1] if not math.isnan(v)]
            if not math.isnan(rmse) and (not prev or rmse < min(prev)):
                hist["best_epoch"] = start
                best_state = cpu_state(model, clone=True)
                new_best = True
            model.train()
        progress["epoch"] += 1
        progress["batch"] = 0
        progress["epoch_start_step"] = progress["step"]
        return best_state, new_best

    def _prepare_training(self, model: torch.nn.Module, device: torch.device) -> tuple[Any, Any, Any]:
        """Move ``model`` to ``device`` (channels-last if asked) and build the Adam optimizer,
        the autocast context and the CUDA gradient scaler (None when not needed).

        Shared by :meth:`_train` and ``estimators.learned.distributed`` so both train alike.
        """
        model.to(device)
        if self.channels_last:
            model.to(memory_format=torch.channels_last)
        optimizer = torch.optim.Adam(model.parameters(), lr=self.lr, weight_decay=self.weight_decay)
        autocast, needs_scaler = self._autocast(device)
        scaler = torch.amp.GradScaler("cuda") if needs_scaler else None
        return optimizer, autocast, scaler

    def _train_step(self, model, optimizer, scaler, autocast, gt, hole, device) -> float:
        gt = gt.to(device, non_blocking=True)
        hole = hole.to(device, non_blocking=True)
        target = gt / self.max_depth
        observed = torch.where(hole, torch.zeros_like(gt), gt)
        scale = self._input_scale(observed)
        x = encode_input(observed, hole, scale, self.input_mask)
        if self.channels_last:
            x = x.contiguous(memory_format=torch.channels_last)
        optimizer.zero_grad(set_to_none=True)
        with autocast:
            pred = model(x)[:, 0]
        # The loss always compares depths divided by max_depth, whatever the input scale.
        pred = pred.float() * (scale / self.max_depth)
        loss = inpainting_loss(pred, target, gt > 0, hole, self.hole_weight, self.tv_weight)
        return backward_step(loss, optimizer, scaler)

    def _resume(self, run_dir: Path, model: UNet, optimizer, device) -> tuple[dict, dict | None] | None:
        state = ckpt.read_run_state(run_dir, owned=True)  # the run folder is this fit's own
        if state is None:
            return None
        _, weights, progress, optim = ckpt.read_checkpoint(run_dir / state["last"], training=True, owned=True)
        model.load_state_dict(weights)
        meta = progress.pop("optimizer")
        optimizer.load_state_dict(ckpt.unflatten_optimizer_state(optim, meta))
        for k in ("optimizer_sha256", "weights_sha256"):
            progress.pop(k, None)
        best = None
        if state.get("best"):
            _, best, _, _ = ckpt.read_checkpoint(run_dir / state["best"], owned=True)
        return progress, best

    def _warm_start_model(self) -> UNet:
        ws = self.warm_start
        if isinstance(ws, TrainingMixin):
            if not hasattr(ws, "model_"):
                raise InvalidInputError(
                    "warm_start estimator is not fitted (note: clone(), as in GridSearchCV, "
                    "drops fitted state; pass a path written by .save() instead)"
                )
            return ws.model_
        if isinstance(ws, (str, os.PathLike)):
            return self._load_warm_start(ws).model_
        raise InvalidTypeError(f"warm_start must be None, a path, or a fitted neural inpainter, got {type(ws).__name__}")

    def _load_warm_start(self, path: str | os.PathLike) -> TrainingMixin:
        """The fitted neural inpainter saved at ``path`` (any class of the family)."""
        raise NotImplementedError(f"{type(self).__name__} cannot load a warm start from a path")

    def _validation_rmse(self, model, val_ds: DepthDataset, protocol, seed: int, device) -> float:
        parts = []
        for start in range(0, len(val_ds), self.batch_size):
            idx = range(start, min(start + self.batch_size, len(val_ds)))
            gt = np.stack([
                check_depth(val_ds[i], name=f"validation frame {frame_label(val_ds, i)}", ndim=(2,)) for i in idx
            ])
            hole = protocol.masks(val_ds.frame_shape, seed, idx)
            x = np.where(hole, np.nan, gt).astype(np.float32)
            pred = self._forward(model, x, device)
            pred = np.where(x > 0, x, np.maximum(pred, 0.0)) if self.keep_observed else pred
            # A net's output clipped at 0 m is its estimate: scored as 0 m (as in score()).
            parts.append(frame_metrics(pred, gt, hole, max_depth=self.max_depth, unfilled="zero"))
        table = aggregate({k: np.concatenate([np.atleast_1d(p[k]) for p in parts]) for k in parts[0]})
        return float(table["hole_rmse"])


def _fitted_summary(progress: dict[str, Any]) -> dict[str, Any]:
    return {"n_steps_": progress["step"], "history_": progress["history"]}


def _copy_encoder(source: UNet, target: UNet) -> None:
    """Copy ``source.encoder`` into ``target.encoder``; shapes must agree."""
    src, dst = source.encoder.state_dict(), target.encoder.state_dict()
    mismatch = [k for k in dst if k not in src or src[k].shape != dst[k].shape]
    if mismatch:
        raise InvalidInputError(
            "warm_start encoder does not match this model (width/depth/input_mask must be "
            f"equal): source in_channels={source.in_channels}, width={source.width}, depth={source.depth}; "
            f"target in_channels={target.in_channels}, width={target.width}, depth={target.depth}"
        )
    target.encoder.load_state_dict({k: src[k].to("cpu") for k in dst})

