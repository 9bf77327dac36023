"""Training samples of the neural inpainters: seeded crops, occlusions and augmentations,
their loader and input encoding.

Every random choice of a training sample (crop offset, occlusion mask, flip, depth factor)
comes from generators seeded by ``(seed, epoch, index)`` alone, and the visiting order of
an epoch from ``(seed, epoch)``, so a sample does not depend on which worker loads it, on
the device that assembles it (:mod:`._sampling`) or on an interruption.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass

import numpy as np
import torch
from torch.utils.data import DataLoader, Dataset

from inpaintenv.conventions import check_depth
from inpaintenv.data.base import DepthDataset
from inpaintenv.data.inputs import input_kind
from inpaintenv.exceptions import InvalidInputError
from inpaintenv.masks import OcclusionProtocol

__all__ = ["Augmentation", "OcclusionFrames", "SampleDraw", "crop_shape", "data_fingerprint", "encode_input",
           "epoch_order", "frame_label", "input_frame", "make_loader", "sample_rng", "scan_input"]

#: Stream id of the epoch order, distinct from any frame index.
_ORDER_STREAM = 2**31 - 1
#: Fourth seed word of a sample's augmentation draws: a stream apart from its crop and mask,
#: so turning augmentation on leaves every crop and occlusion as it was.
_AUGMENT_STREAM = 1


def sample_rng(seed: int, epoch: int, index: int) -> np.random.Generator:
    """Generator of the crop and mask of training sample ``index`` in ``epoch``."""
    return np.random.default_rng(np.random.SeedSequence([seed, epoch, index]))


def epoch_order(n: int, seed: int, epoch: int) -> np.ndarray:
    """The shuffled visiting order of ``n`` frames in ``epoch``."""
    return sample_rng(seed, epoch, _ORDER_STREAM).permutation(n)


def crop_shape(frame_shape: tuple[int, int], crop: tuple[int, int] | None) -> tuple[int, int]:
    """Shape of the training samples: ``crop`` with each side clipped to the frame."""
    fh, fw = (int(v) for v in frame_shape)
    return (fh, fw) if crop is None else (min(int(crop[0]), fh), min(int(crop[1]), fw))


@dataclass(frozen=True)
class Augmentation:
    """Random changes of a training sample beyond its crop and occlusion.

    Parameters
    ----------
    flip : bool
        Mirror the sample left-right with probability 0.5 (depth and hole together).
    depth_jitter : float or None
        Multiply the sample's depth by ``exp(U(-log r, log r))`` for ``r = depth_jitter``
        (log-uniform on ``[1/r, r]``), a scene nearer or farther; None: no scaling.
    """

    flip: bool = False
    depth_jitter: float | None = None

    @property
    def active(self) -> bool:
        return bool(self.flip) or self.depth_jitter is not None

    def draw(self, seed: int, epoch: int, index: int) -> tuple[bool, np.float32]:
        """Whether sample ``index`` of ``epoch`` is flipped, and its depth factor (float32)."""
        if not self.active:
            return False, np.float32(1.0)
        rng = np.random.default_rng(np.random.SeedSequence([seed, epoch, index, _AUGMENT_STREAM]))
        # Both numbers always drawn: turning one augmentation on never moves the other's draws.
        u_flip, u_scale = rng.random(2)
        factor = 1.0 if self.depth_jitter is None else math.exp((2.0 * u_scale - 1.0) * math.log(self.depth_jitter))
        return bool(self.flip) and bool(u_flip < 0.5), np.float32(factor)


@dataclass(frozen=True)
class SampleDraw:
    """The random choices of one training sample: crop offset, occlusion, flip, depth factor.

    ``hole`` is the occlusion drawn on the crop's shape, or None when it was drawn as
    ``rects`` (``(top, left, height, width)`` of ``rect-v1``, rasterised by the device path).
    """

    top: int
    left: int
    hole: np.ndarray | None
    rects: list[tuple[int, int, int, int]] | None
    flip: bool
    factor: np.float32


class OcclusionFrames(Dataset):
    """Torch view of a :class:`DepthDataset`: ``(ground truth, hole)`` per frame.

    Each item is a random crop (or the whole frame) with a fresh occlusion drawn from
    ``protocol`` on the crop's shape, both seeded by ``(seed, epoch, index)``, then the
    ``augment`` draws (flip, depth factor) from their own stream of the same triple. Every
    frame is validated (:meth:`~inpaintenv.data.DepthDataset.checked_frame`) as it is loaded,
    so NaN, inf or negative depth in any frame stops training with an error naming
    the frame instead of surfacing later as a NaN loss or training silently. An item is a
    frame index (of the epoch in :attr:`epoch`) or an ``(epoch, index)`` pair, which the
    training loop's loader passes so that workers kept across epochs need no update.

    Parameters
    ----------
    frames : DepthDataset
    protocol : OcclusionProtocol
    crop : (int, int) or None
        Crop size; each side is clipped to the frame size.
    seed : int
    augment : Augmentation or None
        None: crops and occlusions only.
    """

    def __init__(self, frames: DepthDataset, protocol: OcclusionProtocol, crop: tuple[int, int] | None, seed: int,
                 augment: Augmentation | None = None):
        self.frames = frames
        self.protocol = protocol
        self.crop = crop_shape(frames.frame_shape, crop)
        self.seed = int(seed)
        self.augment = augment or Augmentation()
        self.epoch = 0

    def __len__(self) -> int:
        return len(self.frames)

    def key(self, item: int | tuple[int, int]) -> tuple[int, int]:
        """``(epoch, index)`` of an item (a bare index belongs to :attr:`epoch`)."""
        if isinstance(item, (tuple, list)):
            return int(item[0]), int(item[1])
        return self.epoch, int(item)

    def frame(self, index: int) -> np.ndarray:
        """Frame ``index``, whole, validated."""
        return self.frames.checked_frame(index, f"training frame {frame_label(self.frames, index)}")

    def draw(self, epoch: int, index: int, rectangles: bool = False) -> SampleDraw:
        """The random choices of sample ``index`` in ``epoch``; ``rectangles``: the occlusion as
        ``protocol.rectangles`` (same generator, same draws as ``protocol.sample``)."""
        rng = sample_rng(self.seed, epoch, index)
        (fh, fw), (ch, cw) = tuple(self.frames.frame_shape), self.crop
        top = int(rng.integers(0, fh - ch + 1))
        left = int(rng.integers(0, fw - cw + 1))
        rects = self.protocol.rectangles((ch, cw), rng) if rectangles else None
        hole = None if rectangles else self.protocol.sample((ch, cw), rng)
        flip, factor = self.augment.draw(self.seed, epoch, index)
        return SampleDraw(top, left, hole, rects, flip, factor)

    def __getitem__(self, item: int | tuple[int, int]) -> tuple[torch.Tensor, torch.Tensor]:
        epoch, index = self.key(item)
        gt = self.frame(index)
        d, (ch, cw) = self.draw(epoch, index), self.crop
        gt, hole = gt[d.top : d.top + ch, d.left : d.left + cw], d.hole
        if d.flip:
            gt, hole = gt[:, ::-1], hole[:, ::-1]
        gt = np.ascontiguousarray(gt)
        if d.factor != 1.0:
            gt = gt * d.factor  # float32 times float32: the same rounding as the device path
        return torch.from_numpy(gt), torch.from_numpy(np.ascontiguousarray(hole))


def scan_input(dataset: DepthDataset) -> bool:
    """Whether ``dataset``'s method input is a separate LiDAR scan (``input_kind == "scan"``)
    rather than its ground-truth map with holes cut into it."""
    return input_kind(getattr(dataset, "input_kind", "map")).separate


def input_frame(dataset: DepthDataset, index: int, gt: np.ndarray) -> np.ndarray:
    """The measured input of frame ``index`` (its scan, validated) or, for a map dataset, ``gt``."""
    if not scan_input(dataset):
        return gt
    label = f"training scan {frame_label(dataset, index)}"
    scan = check_depth(dataset.input_frame(index), name=label, ndim=(2,))
    if scan.shape != gt.shape:
        raise InvalidInputError(f"{label} has shape {scan.shape}, its ground truth {gt.shape}")
    return scan


def frame_label(frames: DepthDataset, index: int) -> str:
    """``"3 (id 'drive_a/3')"``: a frame's index and, when the dataset has them, its id."""
    ids = getattr(frames, "frame_ids", None)
    try:
        return f"{index} (id {ids[index]!r})" if ids is not None else str(index)
    except (IndexError, TypeError):  # a custom dataset with incomplete ids: index only
        return str(index)


def _worker_init(_: int) -> None:
    # Loader workers only decode and crop; one thread each leaves the cores to training.
    torch.set_num_threads(1)


def make_loader(
    data: OcclusionFrames, order: np.ndarray, batch_size: int, num_workers: int, pin_memory: bool
) -> DataLoader:
    """A loader visiting ``order`` (a list of frame indices) in batches, in that order.

    Its generator (which only seeds the workers' torch streams; samples are seeded by
    ``(seed, epoch, index)``) is its own: drawing from the global torch stream each epoch
    would make a run resumed mid-epoch draw once more than the uninterrupted one.
    """
    return DataLoader(
        data,
        batch_size=batch_size,
        sampler=order.tolist(),
        num_workers=num_workers,
        pin_memory=pin_memory,
        worker_init_fn=_worker_init if num_workers else None,
        drop_last=False,
        generator=torch.Generator().manual_seed(int(np.random.SeedSequence([data.seed, data.epoch]).generate_state(1)[0])),
    )


def encode_input(
    depth: torch.Tensor, hole: torch.Tensor, max_depth: float | torch.Tensor, input_mask: bool
) -> torch.Tensor:
    """Network input from observed depth (0 in holes and where unmeasured) and holes.

    Parameters
    ----------
    depth : torch.Tensor
        ``(N, H, W)`` metres, finite, 0 inside holes.
    hole : torch.Tensor
        ``(N, H, W)`` bool.
    max_depth : float or torch.Tensor
        Normalisation range (the study's 80 m), or a per-frame ``(N, 1, 1)`` scale.
    input_mask : bool
        False: one channel, ``depth / max_depth`` (the study). True: three channels,
        adding the hole mask and the validity mask (``depth > 0``).

    Returns
    -------
    torch.Tensor
        ``(N, C, H, W)`` float32.
    """
    x = (depth / max_depth).unsqueeze(1)
    if not input_mask:
        return x
    return torch.cat([x, hole.unsqueeze(1).to(x.dtype), (depth > 0).unsqueeze(1).to(x.dtype)], dim=1)


def data_fingerprint(dataset: DepthDataset) -> str:
    """A cheap identity of a dataset: ids, size, and the content of its first/last frame.

    Used to name per-fit checkpoint directories, so two folds (or two datasets) never
    share one, while refitting the same data resumes.
    """
    h = hashlib.sha256()
    h.update(f"{type(dataset).__name__}|{len(dataset)}|{tuple(dataset.frame_shape)}|".encode())
    h.update("\n".join(map(str, dataset.frame_ids)).encode())
    for i in sorted({0, len(dataset) - 1}):
        h.update(np.ascontiguousarray(dataset[i], dtype=np.float32).tobytes())
    return h.hexdigest()
