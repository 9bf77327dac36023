"""Data-parallel training of the neural inpainters with DistributedDataParallel.

Launch one process per device with ``torchrun``::

    torchrun --nproc_per_node=2 -m estimators.distributed \\
        --preset study-unet-tv --kitti-root /data/kitti --out runs/ddp --max-steps 1000

or call :func:`train_distributed` from a process whose environment ``torchrun`` (or
the caller) filled with ``RANK``, ``WORLD_SIZE``, ``LOCAL_RANK``, ``MASTER_ADDR`` and
``MASTER_PORT``.

Semantics (see ``docs/neural.md``, "Multi-process / multi-GPU training"):

* ``batch_size`` of the estimator is the **global** batch: every optimiser step sees
  ``batch_size`` frames split over the ``WORLD_SIZE`` processes, so a preset means the
  same recipe (and learning rate) on any number of processes.
* The epoch order is the single-process one (:func:`~estimators.learned._training.epoch_order`);
  global batch ``k`` is ``order[k*B:(k+1)*B]`` and rank ``r`` takes its elements
  ``r, r+W, ...`` (a :class:`~torch.utils.data.distributed.DistributedSampler` over the
  existing deterministic order). A trailing incomplete global batch is skipped in that
  epoch (``drop_last``); the next epoch reshuffles.
* DDP averages the gradients of the ranks; the logged loss is the mean of the ranks'
  losses. Both equal the single-process values for the same global batch when every
  rank's loss pools the same number of pixels (see the docs for when they differ).
* Rank 0 alone writes checkpoints (the estimator's atomic run checkpoints) and logs;
  every rank resumes from them, so a killed job restarted with the same command
  continues where it stopped.
"""

from __future__ import annotations

import argparse
import contextlib
import gc
import math
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import torch
import torch.distributed as dist
from torch.nn.parallel import DistributedDataParallel

from inpaintenv.data.base import DepthDataset, as_dataset
from inpaintenv.masks import get_protocol

from ..base import resolve_seed
from . import _checkpoint as ckpt
from ._training import OcclusionFrames, epoch_order, make_loader, torch_threads
from .neural import (
    AutoencoderInpainter,
    UNetInpainter,
    _copy_encoder,
    _cpu_state,
    _fitted_summary,
    _NeuralInpainter,
)

__all__ = ["main", "rank_order", "train_distributed"]

_ENV = ("RANK", "WORLD_SIZE", "LOCAL_RANK", "MASTER_ADDR", "MASTER_PORT")


def rank_order(order: np.ndarray, batch_size: int, rank: int, world_size: int) -> np.ndarray:
    """The frames rank ``rank`` visits, in step order, for one epoch's ``order``.

    Global batch ``k`` is ``order[k*batch_size:(k+1)*batch_size]``; the rank takes its
    elements ``rank, rank + world_size, ...``. Incomplete trailing global batches are
    dropped, so every rank takes ``batch_size // world_size`` frames per step.
    """
    n_full = len(order) // batch_size
    return order[: n_full * batch_size].reshape(n_full, batch_size)[:, rank::world_size].reshape(-1)


@contextlib.contextmanager
def process_group(device_type: str) -> Iterator[tuple[int, int, int]]:
    """Join (or reuse) the process group described by the torchrun environment.

    Yields ``(rank, world_size, local_rank)``; a group created here is destroyed after.
    """
    if dist.is_initialized():
        yield dist.get_rank(), dist.get_world_size(), int(os.environ.get("LOCAL_RANK", "0"))
        return
    missing = [k for k in _ENV if k not in os.environ]
    if missing:
        raise RuntimeError(
            f"distributed training needs the torchrun environment; missing {', '.join(missing)}. "
            "Launch with `torchrun --nproc_per_node=N -m estimators.distributed ...`"
        )
    dist.init_process_group(backend="nccl" if device_type == "cuda" else "gloo")
    try:
        yield dist.get_rank(), dist.get_world_size(), int(os.environ["LOCAL_RANK"])
        # Leave together (rank 0 writes the last checkpoint after the others are done).
        # Not on an error: the other ranks may never reach the barrier.
        dist.barrier()
    finally:
        # The DDP wrapper sits in reference cycles; left to the collector, it could outlive
        # the group, and a rank then aborted now and then at interpreter exit ("terminate
        # called without an active exception" in gloo's threads, ~1 run in 10).
        gc.collect()
        dist.destroy_process_group()


def _shared_seed(est: _NeuralInpainter) -> int:
    """``random_state``'s seed, or a seed drawn by rank 0 (None, a generator) and sent to every rank."""
    if est.random_state is not None and not isinstance(est.random_state, (np.random.RandomState, np.random.Generator)):
        return int(est.random_state)
    box = [resolve_seed(est.random_state)]
    dist.broadcast_object_list(box, src=0)
    return int(box[0])


def train_distributed(
    est: _NeuralInpainter, X: Any, *, log: bool = True
) -> _NeuralInpainter:
    """Fit ``est`` on ``X`` data-parallel over the processes of a torchrun job.

    Parameters
    ----------
    est : UNetInpainter or AutoencoderInpainter
        Unfitted configuration. ``batch_size`` is the global batch and must be a
        multiple of ``WORLD_SIZE``; ``checkpoint_dir``/``checkpoint_every`` behave as in
        ``fit`` (rank 0 writes, every rank resumes). ``validation_fraction`` and
        ``warm_start=True`` are not supported here.
    X : DepthDataset or array-like
        Training ground truth; every rank must pass the same frames.
    log : bool
        Rank 0 prints one line per checkpoint and at the end.

    Returns
    -------
    estimator
        ``est``, fitted, on every rank (the ranks hold identical weights).

    Raises
    ------
    ValueError
        Unsupported parameters, or a batch that does not split over the ranks.
    RuntimeError
        Outside a torchrun environment.
    """
    # Exactly these two: subclasses (e.g. PriorUNetInpainter) train differently.
    if type(est) not in (UNetInpainter, AutoencoderInpainter):
        raise TypeError(f"train_distributed needs a UNetInpainter or AutoencoderInpainter, got {type(est).__name__}")
    est._check_params()
    if est.validation_fraction is not None:
        raise ValueError("validation_fraction is not supported by distributed training; validate after fit")
    if est.warm_start is True:
        raise ValueError("warm_start=True is not supported by distributed training; pass a saved model path")
    dataset = as_dataset(X)
    if len(dataset) == 0:
        raise ValueError("cannot fit on an empty dataset")
    est._check_frame_size(dataset.frame_shape)
    device = est._device()
    with process_group(device.type) as (rank, world, local_rank), torch_threads(est.num_threads):
        if est.batch_size % world:
            raise ValueError(f"batch_size={est.batch_size} (the global batch) is not a multiple of WORLD_SIZE={world}")
        if len(dataset) < est.batch_size:
            raise ValueError(f"{len(dataset)} frames are fewer than one global batch of {est.batch_size}")
        if device.type == "cuda":
            device = torch.device("cuda", local_rank)
            torch.cuda.set_device(device)
        seed = _shared_seed(est)
        _train(est, dataset, seed, device, rank, world, log)
        est.seed_ = seed
        est.model_params_ = est._model_params()
        est.is_fitted_ = True
    return est


def _train(est: _NeuralInpainter, dataset: DepthDataset, seed: int, device: torch.device,
           rank: int, world: int, log: bool) -> None:
    model = est._build_model(seed)  # same seed on every rank; DDP also broadcasts rank 0's
    if est.warm_start not in (None, False):
        _copy_encoder(est._warm_start_model(), model)
    optimizer, autocast, scaler = est._prepare_training(model, device)

    progress: dict[str, Any] = {
        "epoch": 0, "batch": 0, "step": 0, "finished": False, "epoch_start_step": 0,
        "history": {"step_loss": [], "epoch_loss": [], "val_hole_rmse": [], "best_epoch": None},
    }
    # A run directory of its own: a step here is a global batch with drop_last, so its
    # progress must never be resumed by a single-process fit (or another world size).
    run_dir = est._run_dir(dataset, seed)
    if run_dir is not None:
        run_dir = run_dir.with_name(f"ddp{world}-{run_dir.name}")
        resumed = est._resume(run_dir, model, optimizer, device)
        if resumed is not None:
            progress = resumed[0]
    est.run_dir_ = run_dir
    ddp = DistributedDataParallel(model, device_ids=[device.index] if device.type == "cuda" else None)
    # Compile the DDP wrapper (not the inner module), as torch's DDP notes advise, so
    # graph breaks line up with the gradient buckets.
    step_model = est._compiled(ddp)
    config = {"class": type(est).__name__, "params": est._config_params(), "seed": seed,
              "torch_threads": torch.get_num_threads(), "world_size": world}

    def save() -> None:
        if run_dir is None or rank != 0:
            return
        tensors, meta = ckpt.flatten_optimizer_state(optimizer.state_dict())
        ckpt.write_run_checkpoint(run_dir, progress["step"], {**config, "fitted": _fitted_summary(progress)},
                                  _cpu_state(model), {**progress, "optimizer": meta}, tensors)
        if log:
            print(f"[rank 0/{world}] step {progress['step']}: checkpoint {run_dir}", flush=True)

    hist = progress["history"]
    data = OcclusionFrames(dataset, get_protocol(est.protocol), est.crop, seed)
    local_batch = est.batch_size // world
    steps_per_epoch = len(dataset) // est.batch_size
    while not progress["finished"]:
        epoch = progress["epoch"]
        data.epoch = epoch
        order = rank_order(epoch_order(len(dataset), seed, epoch), est.batch_size, rank, world)
        order = order[progress["batch"] * local_batch:]
        stopped = False
        ddp.train()
        for gt, hole in make_loader(data, order, local_batch, est.num_workers, device.type == "cuda"):
            # The estimator's own step (input encoding, loss, AMP); DDP's backward hooks
            # all-reduce (average) the gradients before optimizer.step().
            local = est._train_step(step_model, optimizer, scaler, autocast, gt, hole, device)
            loss = torch.tensor([local], dtype=torch.float64, device=device)
            dist.all_reduce(loss)
            hist["step_loss"].append(float(loss.item()) / world)
            progress["step"] += 1
            progress["batch"] += 1
            if est.max_steps is not None and progress["step"] >= est.max_steps:
                stopped = True
                break
            if est.checkpoint_every and progress["step"] % est.checkpoint_every == 0:
                save()
        done = hist["step_loss"][progress["epoch_start_step"]:]
        hist["epoch_loss"].append(float(np.mean(done)) if done else float("nan"))
        progress.update(epoch=epoch + 1, batch=0, epoch_start_step=progress["step"])
        progress["finished"] = stopped or progress["epoch"] >= est.epochs or steps_per_epoch == 0
        save()
    if log and rank == 0:
        last = hist["step_loss"][-1] if hist["step_loss"] else math.nan
        print(f"[rank 0/{world}] done: {progress['step']} steps, last loss {last:.5f}", flush=True)
    est.model_ = model.to("cpu", memory_format=torch.contiguous_format).eval()
    est.history_ = hist
    est.n_steps_ = progress["step"]


def main(argv: list[str] | None = None) -> int:
    """Command line: ``torchrun --nproc_per_node=N -m estimators.distributed ...``."""
    from inpaintenv.data import open_source

    from .presets import PRESETS, make_preset

    p = argparse.ArgumentParser(prog="python -m estimators.distributed", description=__doc__.split("\n")[0])
    p.add_argument("--preset", required=True, help="a single-stage U-Net/autoencoder preset, e.g. study-unet-tv")
    p.add_argument("--kitti-root", default=None, help="KITTI depth root (default: the synthetic streets)")
    p.add_argument("--split", default="train")
    p.add_argument("--n-frames", type=int, default=None)
    p.add_argument("--out", required=True, type=Path, help="run checkpoints and the final model go here")
    p.add_argument("--max-steps", type=int, default=None)
    p.add_argument("--batch-size", type=int, default=None, help="global batch (default: the preset's)")
    p.add_argument("--checkpoint-every", type=int, default=None)
    p.add_argument("--num-threads", type=int, default=None, help="torch threads per process")
    args = p.parse_args(argv)
    if args.preset not in PRESETS:
        p.error(f"unknown preset {args.preset!r}; known: {', '.join(PRESETS)}")
    overrides = {k: v for k, v in {"max_steps": args.max_steps, "batch_size": args.batch_size,
                                   "checkpoint_every": args.checkpoint_every,
                                   "num_threads": args.num_threads}.items() if v is not None}
    est = make_preset(args.preset, checkpoint_dir=args.out, **overrides)
    if type(est) not in (UNetInpainter, AutoencoderInpainter):
        p.error(f"preset {args.preset!r} builds a {type(est).__name__}; distributed training supports "
                "the U-Net/autoencoder presets")
    dataset = open_source(args.kitti_root, split=args.split, n_frames=args.n_frames)
    train_distributed(est, dataset)
    if int(os.environ.get("RANK", "0")) == 0:
        path = est.save(args.out / "model")
        print(f"saved {path} (load with estimators.neural.load_checkpoint)", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
