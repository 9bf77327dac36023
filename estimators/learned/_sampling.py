"""Where a training run's batches are assembled: one loader for the whole run, and the
optional path that crops, occludes and augments on the training device.

Both paths take every random choice from :meth:`OcclusionFrames.draw` (generators seeded by
``(seed, epoch, index)``, drawn on the CPU: a few numbers a sample), so the same seed gives
the same samples whichever path, device or number of workers assembles them. The device
path only moves the pixel work: the loader's workers decode and validate whole frames, and
the crop, the ``rect-v1`` rectangles, the flip and the depth factor are applied on the
device (other protocols draw their mask on the CPU, as the loader path does, and send it).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence

import numpy as np
import torch
from torch.utils.data import DataLoader, Dataset, Sampler

from inpaintenv.masks import OcclusionProtocol
from inpaintenv.masks.rect import RectV1

from ._training_data import OcclusionFrames, SampleDraw, _worker_init

__all__ = ["EpochSampler", "TrainingBatches", "WholeFrames", "device_samples", "draws_rectangles", "rasterise"]


class EpochSampler(Sampler):
    """The ``(epoch, index)`` items of the current epoch, in order (set by :meth:`set`).

    One sampler for the whole run: a loader with persistent workers draws each epoch's
    items from it anew, and the epoch travels in the item, not in the workers' copy of
    the dataset.
    """

    def __init__(self) -> None:
        self.items: list[tuple[int, int]] = []

    def set(self, epoch: int, order: Sequence[int]) -> None:
        self.items = [(int(epoch), int(i)) for i in order]

    def __iter__(self) -> Iterator[tuple[int, int]]:
        return iter(self.items)

    def __len__(self) -> int:
        return len(self.items)


class WholeFrames(Dataset):
    """The loader's items on the device path: ``(whole validated frame, epoch, index)``."""

    def __init__(self, data: OcclusionFrames):
        self.data = data

    def __len__(self) -> int:
        return len(self.data)

    def __getitem__(self, item: tuple[int, int]) -> tuple[torch.Tensor, int, int]:
        epoch, index = self.data.key(item)
        return torch.from_numpy(np.ascontiguousarray(self.data.frame(index))), epoch, index


def draws_rectangles(protocol: OcclusionProtocol) -> bool:
    """Whether ``protocol``'s masks are exactly its ``rectangles`` filled in (``rect-v1``), so
    the device can rasterise them from the same draws."""
    return isinstance(protocol, RectV1) and type(protocol).sample is RectV1.sample


def rasterise(rects: Sequence[Sequence[tuple[int, int, int, int]]], shape: tuple[int, int],
              device: torch.device) -> torch.Tensor:
    """``(N, H, W)`` bool masks, True inside any ``(top, left, height, width)`` of each sample."""
    n_max = max((len(r) for r in rects), default=0)
    table = torch.zeros((len(rects), max(n_max, 1), 4), dtype=torch.int64)
    for k, sample in enumerate(rects):
        if sample:
            table[k, : len(sample)] = torch.tensor(sample, dtype=torch.int64)
    top, left, h, w = table.to(device).unbind(-1)  # (N, R) each; padding rows have h = w = 0
    rows = torch.arange(shape[0], device=device)
    cols = torch.arange(shape[1], device=device)
    in_rows = (rows >= top[..., None]) & (rows < (top + h)[..., None])  # (N, R, H)
    in_cols = (cols >= left[..., None]) & (cols < (left + w)[..., None])  # (N, R, W)
    return (in_rows[..., :, None] & in_cols[..., None, :]).any(dim=1)


def device_samples(data: OcclusionFrames, frames: torch.Tensor, epochs: Sequence[int],
                   indices: Sequence[int]) -> tuple[torch.Tensor, torch.Tensor]:
    """``(ground truth, hole)`` of the samples ``(epochs[k], indices[k])`` from their whole
    ``frames`` (``(N, H, W)``, already on the device): the loader path's tensors, bit for bit."""
    rect = draws_rectangles(data.protocol)
    draws: list[SampleDraw] = [data.draw(int(e), int(i), rectangles=rect) for e, i in zip(epochs, indices)]
    device, (ch, cw) = frames.device, data.crop
    gt = torch.stack([f[d.top : d.top + ch, d.left : d.left + cw] for f, d in zip(frames, draws)])
    if rect:
        hole = rasterise([d.rects for d in draws], (ch, cw), device)
    else:
        hole = torch.from_numpy(np.stack([d.hole for d in draws])).to(device, non_blocking=True)
    flip = [d.flip for d in draws]
    if any(flip):
        flip_t = torch.tensor(flip, device=device)[:, None, None]
        gt, hole = torch.where(flip_t, gt.flip(-1), gt), torch.where(flip_t, hole.flip(-1), hole)
    factors = np.array([d.factor for d in draws], dtype=np.float32)
    if (factors != 1.0).any():
        gt = gt * torch.from_numpy(factors).to(device)[:, None, None]
    return gt.contiguous(), hole.contiguous()


class TrainingBatches:
    """The batches of one training run, from one ``DataLoader`` kept for all its epochs.

    With ``num_workers > 0`` the workers persist across epochs (no restart, no refill of
    the prefetch queue at every epoch) and batches are pinned when training on CUDA.
    ``on_device`` assembles each batch on ``device`` from whole frames (:func:`device_samples`).

    Parameters
    ----------
    data : OcclusionFrames
    batch_size : int
        Frames this process loads per step.
    num_workers : int
    device : torch.device
        Where the network trains.
    on_device : bool
        Crop, occlude and augment on ``device`` instead of in the loader.
    """

    def __init__(self, data: OcclusionFrames, batch_size: int, num_workers: int, device: torch.device,
                 on_device: bool):
        self.data, self.device, self.on_device = data, device, bool(on_device)
        self.sampler = EpochSampler()
        seed = int(np.random.SeedSequence([data.seed]).generate_state(1)[0])
        self.loader: DataLoader | None = DataLoader(
            WholeFrames(data) if self.on_device else data,
            batch_size=batch_size,
            sampler=self.sampler,
            num_workers=num_workers,
            pin_memory=device.type == "cuda",
            worker_init_fn=_worker_init if num_workers else None,
            persistent_workers=num_workers > 0,
            drop_last=False,
            # Its own generator (it only seeds the workers' torch streams): drawing from the
            # global one would make a resumed run draw once more than the uninterrupted one.
            generator=torch.Generator().manual_seed(seed),
        )

    def epoch(self, epoch: int, order: Sequence[int]) -> Iterator[tuple[torch.Tensor, torch.Tensor]]:
        """The batches of ``order`` (frame indices) in ``epoch``: ``(ground truth, hole)``."""
        if self.loader is None:
            raise RuntimeError("these training batches are closed")
        self.data.epoch = int(epoch)
        self.sampler.set(epoch, order)
        if not self.on_device:
            yield from self.loader
            return
        for frames, epochs, indices in self.loader:
            yield device_samples(self.data, frames.to(self.device, non_blocking=True), epochs.tolist(),
                                 indices.tolist())

    def close(self) -> None:
        """Let the workers go (a persistent loader keeps them until it is dropped)."""
        self.loader = None
