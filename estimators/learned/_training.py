"""Training of the neural inpainters through the one fitting loop (:mod:`._loop`): their run
folder, warm start, steps over frames, validation and threads (samples: :mod:`._training_data`;
their loader and the device path: :mod:`._sampling`).

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
from inpaintenv.exceptions import InvalidInputError, InvalidTypeError
from inpaintenv.masks import get_protocol
from inpaintenv.metrics import aggregate, frame_metrics

from ..base import resolve_seed
from ._loop import Constant, Optimisation, RunFolder, RunPlan, Schedule, Shard, fit_loop, new_progress
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


#: Parameters that change nothing about the trained weights: left out of the run-directory
#: hash so that e.g. changing ``verbose`` still resumes the same run (and a run stopped by
#: its ``max_minutes`` continues when fit is called again).
_RUN_INDEPENDENT = ("verbose", "num_workers", "num_threads", "checkpoint_dir", "checkpoint_every", "keep_observed",
                    "max_minutes", "sample_device")


class TrainingMixin:
    """What a neural inpainter gives :func:`~._loop.fit_loop`: run directory, warm start, the
    step over a batch of frames and per-epoch validation (``fit`` of :class:`estimators.learned._neural._NeuralInpainter`).

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
        """Fit ``self.model_`` through :func:`~._loop.fit_loop`, resuming from and writing checkpoints in the run folder.

        ``shard`` splits each global batch over the processes of a distributed job
        (``estimators.learned.distributed``); None trains in this process alone.
        """
        shard = shard or Shard()
        folder = self._run_folder(dataset, seed, shard)
        # One fit per run folder: two at once would delete each other's checkpoints.
        with folder.held() if folder is not None else contextlib.nullcontext():
            self._train_in(dataset, seed, device, shard, folder)

    def _train_in(self, dataset: DepthDataset, seed: int, device: torch.device, shard: Shard,
                  folder: RunFolder | None) -> None:
        """:meth:`_train` in its run ``folder`` (held), or without one."""
        if self.validation_fraction is not None:
            train_ds, val_ds = split_by_drive(dataset, self.validation_fraction, seed=seed)
        else:
            train_ds, val_ds = dataset, None
        shard.check_data(len(train_ds), self.batch_size)
        protocol = get_protocol(self.protocol)
        model = self._initial_model(seed)
        optimisation = self._prepare_training(model, device)
        progress = new_progress(val_hole_rmse=[], best_epoch=None)
        best: dict[str, Any] = {"state": None}
        steps_per_epoch = shard.batches_per_epoch(len(train_ds), self.batch_size)
        if folder is not None:
            plan = RunPlan(epochs=self.epochs, steps_per_epoch=steps_per_epoch, max_steps=self.max_steps,
                           updates_per_step=self._updates_per_step,
                           exact_updates=self._exact_updates and optimisation.scaler is None,
                           validates=val_ds is not None, free_params=_RUN_INDEPENDENT,
                           param_defaults=self._run_key_defaults)
            resumed = folder.resume(model, optimisation, plan)
            if resumed is not None:
                progress, best["state"] = resumed
                self._set_rng_state(progress.pop("rng", None))
                set_global_rng_state(progress.pop("global_rng", None))
        # Wrapped after the resume: DDP broadcasts the (resumed) weights of rank 0.
        step_model = self._compiled(shard.wrap(model, device))
        data = OcclusionFrames(train_ds, protocol, self.crop, seed, self._augmentation())
        local = shard.local_batch(self.batch_size)
        batches = TrainingBatches(data, local, self.num_workers, device, self._sample_on_device(device))

        def epoch_batches(epoch: int, done: int) -> Iterator[tuple[torch.Tensor, torch.Tensor]]:
            step_model.train()
            yield from batches.epoch(epoch, shard.order(epoch_order(len(data), seed, epoch), self.batch_size)[done * local:])

        def end_epoch(progress: dict[str, Any]) -> bool:
            if val_ds is None:
                return False
            hist = progress["history"]
            rmse = self._validation_rmse(model, val_ds, protocol, seed, device)
            hist["val_hole_rmse"].append(rmse)
            prev = [v for v in hist["val_hole_rmse"][:-1] if not math.isnan(v)]
            model.train()
            if math.isnan(rmse) or (prev and rmse >= min(prev)):
                return False
            hist["best_epoch"] = progress["epoch"]
            best["state"] = cpu_state(model, clone=True)
            return True

        def checkpoint(*, new_best: bool = False) -> None:
            if folder is not None:
                rngs = {"rng": self._rng_state(), "global_rng": global_rng_state()}
                folder.write(progress, model, optimisation.optimizer, rngs, new_best=new_best)

        try:
            fit_loop(
                progress, epoch_batches,
                lambda batch: self._train_step(step_model, optimisation, *batch, device),
                epochs=self.epochs, steps_per_epoch=steps_per_epoch,
                max_steps=self.max_steps, desc=type(self).__name__, verbose=bool(self.verbose),
                max_minutes=getattr(self, "max_minutes", None), shard=shard, device=device, end_epoch=end_epoch,
                checkpoint=checkpoint, checkpoint_every=self.checkpoint_every,
            )
        finally:
            batches.close()

        if best["state"] is not None:
            model.load_state_dict(best["state"])
        self.model_ = model.to("cpu", memory_format=torch.contiguous_format).eval()
        self.history_ = progress["history"]
        self.n_steps_ = progress["step"]

    def _run_folder(self, dataset: DepthDataset, seed: int, shard: Shard) -> RunFolder | None:
        """The run folder of this fit (None without ``checkpoint_dir``), named for its shard's split."""
        run_dir = self._run_dir(dataset, seed)
        if run_dir is not None:
            run_dir = run_dir.with_name(shard.run_prefix + run_dir.name)
        self.run_dir_ = run_dir
        if run_dir is None:
            return None
        config = {"class": type(self).__name__, "params": self._config_params(), "seed": seed,
                  "torch_threads": torch.get_num_threads(), **shard.config}
        return RunFolder(run_dir, config, shard)

    def _rng_state(self) -> dict[str, Any] | None:
        """As JSON, the state of a random stream that advances step by step (the PriorUNet's
        flips), so a resume continues it; None: samples depend on ``(seed, epoch, index)`` only."""
        return None

    def _set_rng_state(self, state: dict[str, Any] | None) -> None:
        """Restore what :meth:`_rng_state` returned (None: a checkpoint that recorded none)."""

    #: Parameters left out of the run folder's key at these values, so a run folder keyed
    #: without them resumes.
    _run_key_defaults: dict[str, Any] = {}
    #: The most optimiser updates one training step takes.
    _updates_per_step: int = 1
    #: Whether every step takes exactly that many (a resumed Adam's count is then checked exactly).
    _exact_updates: bool = True

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

    def _prepare_training(self, model: torch.nn.Module, device: torch.device) -> Optimisation:
        """Move ``model`` to ``device`` (channels-last if asked) and build its :class:`~._loop.Optimisation`:
        Adam, the schedule (:meth:`_schedule`), the autocast context and the CUDA gradient scaler.

        Shared by :meth:`_train` and ``estimators.learned.distributed`` so both train alike.
        """
        model.to(device)
        if self.channels_last:
            model.to(memory_format=torch.channels_last)
        autocast, needs_scaler = self._autocast(device)
        scaler = torch.amp.GradScaler("cuda") if needs_scaler else None
        return Optimisation(model, self.lr, self.weight_decay, self._schedule(), autocast, scaler)

    def _schedule(self) -> Schedule:
        """The learning rate per update (constant: the study's recipe)."""
        return Constant()

    def _train_step(self, model: torch.nn.Module, optimisation: Optimisation, gt: torch.Tensor, hole: torch.Tensor,
                    device: torch.device) -> float:
        """One step on a batch of frames ``gt`` with holes ``hole``: one update of the study's loss."""
        gt = gt.to(device, non_blocking=True)
        hole = hole.to(device, non_blocking=True)
        target = gt / self.max_depth
        observed = torch.where(hole, torch.zeros_like(gt), gt)
        scale = self._input_scale(observed)
        x = encode_input(observed, hole, scale, self.input_mask)
        if self.channels_last:
            x = x.contiguous(memory_format=torch.channels_last)

        def loss() -> torch.Tensor:
            with optimisation.autocast:
                pred = model(x)[:, 0]
            # The loss always compares depths divided by max_depth, whatever the input scale.
            pred = pred.float() * (scale / self.max_depth)
            return inpainting_loss(pred, target, gt > 0, hole, self.hole_weight, self.tv_weight)

        return optimisation.update(loss)

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

