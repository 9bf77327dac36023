"""Data-parallel training of the neural inpainters with DistributedDataParallel.

Launch one process per device with ``torchrun``::

    torchrun --nproc_per_node=2 -m estimators.learned.distributed \\
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
* The loop is ``fit``'s (:class:`~estimators.learned._training.TrainingMixin`), so
  validation, warm start, checkpoints and resume work as there; :class:`DistributedShard`
  only swaps the frames each rank loads, wraps the model and averages the logged loss.
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

from inpaintenv.data.base import as_dataset
from inpaintenv.exceptions import InvalidInputError, InvalidTypeError, StateError

from ..base import resolve_seed
from . import _checkpoint as ckpt  # noqa: F401  (tests watch its writes)
from ._neural import AutoencoderInpainter, UNetInpainter, _NeuralInpainter
from ._loop import Shard

__all__ = ["DistributedShard", "main", "rank_order", "train_distributed"]

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
        raise StateError(
            f"distributed training needs the torchrun environment; missing {', '.join(missing)}. "
            "Launch with `torchrun --nproc_per_node=N -m estimators.learned.distributed ...`"
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


class DistributedShard(Shard):
    """Rank ``rank`` of ``world`` processes: a slice of every global batch, DDP's model.

    Global batch ``k`` is ``order[k*B:(k+1)*B]`` of the single-process epoch order; this
    rank takes its elements ``rank, rank + world, ...``; an incomplete trailing global
    batch is dropped. Rank 0 alone writes checkpoints and logs.
    """

    def __init__(self, rank: int, world: int, log: bool = True):
        self.rank, self.world, self.log = int(rank), int(world), bool(log)
        self.writes = self.rank == 0
        # A step here is a global batch with drop_last: its progress must never be
        # resumed by a single-process fit (or another world size).
        self.run_prefix = f"ddp{self.world}-"
        self.config = {"world_size": self.world}

    def check_data(self, n_frames: int, batch_size: int) -> None:
        if batch_size % self.world:
            raise InvalidInputError(f"batch_size={batch_size} (the global batch) is not a multiple of WORLD_SIZE={self.world}")
        if n_frames < batch_size:
            raise InvalidInputError(f"{n_frames} training frames are fewer than one global batch of {batch_size}")

    def batches_per_epoch(self, n_frames: int, batch_size: int) -> int:
        return n_frames // batch_size

    def local_batch(self, batch_size: int) -> int:
        return batch_size // self.world

    def order(self, order: np.ndarray, batch_size: int) -> np.ndarray:
        return rank_order(order, batch_size, self.rank, self.world)

    def wrap(self, model: torch.nn.Module, device: torch.device) -> torch.nn.Module:
        # Compiled by the loop around this wrapper (not the inner module), as torch's DDP
        # notes advise, so graph breaks line up with the gradient buckets.
        return DistributedDataParallel(model, device_ids=[device.index] if device.type == "cuda" else None)

    def mean_loss(self, loss: float, device: torch.device) -> float:
        total = torch.tensor([loss], dtype=torch.float64, device=device)
        dist.all_reduce(total)
        return float(total.item()) / self.world

    def agree_stop(self, stop: bool, device: torch.device) -> bool:
        # Each rank's own clock: the job stops when any rank's budget ran out (no rank waits alone).
        flag = torch.tensor([float(stop)], device=device)
        dist.all_reduce(flag, op=dist.ReduceOp.MAX)
        return bool(flag.item())

    def saved(self, run_dir: Path, step: int) -> None:
        if self.log:
            print(f"[rank 0/{self.world}] step {step}: checkpoint {run_dir}", flush=True)

    def done(self, progress: dict[str, Any]) -> None:
        if self.log and self.writes:
            losses = progress["history"]["step_loss"]
            last = losses[-1] if losses else math.nan
            print(f"[rank 0/{self.world}] done: {progress['step']} steps, last loss {last:.5f}", flush=True)


def train_distributed(
    est: _NeuralInpainter, X: Any, *, log: bool = True
) -> _NeuralInpainter:
    """Fit ``est`` on ``X`` data-parallel over the processes of a torchrun job.

    The training loop is ``fit``'s (validation, warm start, checkpoints and resume
    included); only the frames each process loads, the model (wrapped in
    ``DistributedDataParallel``) and the logged loss (the mean over the ranks) differ.

    Parameters
    ----------
    est : UNetInpainter or AutoencoderInpainter
        ``batch_size`` is the global batch and must be a multiple of ``WORLD_SIZE``;
        ``checkpoint_dir``/``checkpoint_every`` behave as in ``fit`` (rank 0 writes,
        every rank resumes). With ``validation_fraction`` every rank measures the
        held-out drives (the same weights, so the same RMSE and the same best epoch).
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
        Bad parameters, or a batch that does not split over the ranks.
    RuntimeError
        Outside a torchrun environment.
    """
    # Exactly these two: subclasses (e.g. PriorUNetInpainter) train differently.
    if type(est) not in (UNetInpainter, AutoencoderInpainter):
        raise InvalidTypeError(f"train_distributed needs a UNetInpainter or AutoencoderInpainter, got {type(est).__name__}")
    dataset = as_dataset(X)
    if len(dataset) == 0:
        raise InvalidInputError("cannot fit on an empty dataset")
    est._check_fit(dataset)
    device = est._device()
    with process_group(device.type) as (rank, world, local_rank):
        if device.type == "cuda":
            device = torch.device("cuda", local_rank)
            torch.cuda.set_device(device)
        est._fit_on(dataset, _shared_seed(est), device, DistributedShard(rank, world, log))
        est.is_fitted_ = True
    return est


def main(argv: list[str] | None = None) -> int:
    """Command line: ``torchrun --nproc_per_node=N -m estimators.learned.distributed ...``."""
    from inpaintenv.data import open_source

    from .presets import PRESETS, make_preset

    p = argparse.ArgumentParser(prog="python -m estimators.learned.distributed", description=__doc__.split("\n")[0])
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
        print(f"saved {path} (load with estimators.learned.load)", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
