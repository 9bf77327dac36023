"""A learned inpainter built on classical priors: per-pixel blend of candidate fills + residual.

>>> from estimators.learned import load_release                        # doctest: +SKIP
>>> est = load_release("kitti-mixed-v1")                              # shipped weights
>>> est.predict(corrupted)                                           # metres

The network (:class:`estimators.learned.nets.prior_unet.PriorUNet`) sees the corrupted depth,
the hole and validity masks and the classical fills of :mod:`estimators.candidates`
(row-wise depth and inverse-depth interpolation, column-wise interpolation, harmonic),
all computed on the whole frame, and predicts per pixel how to weight them plus a
correction. Training, checkpoints, resuming, validation and saving are those of
:class:`estimators.learned.UNetInpainter`; only the model, the input features, the loss
(L2 on the hole in metres, since the benchmark's metric is RMSE) and flip augmentation /
test-time flip averaging differ. See ``docs/model_card.md`` for the shipped model.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np
import torch

from ..candidates import (
    CANDIDATES,
    ENDPOINT_CHANNELS,
    GAP_CHANNELS,
    check_candidates,
    prior_features,
)
from . import _checkpoint as ckpt
from .._constraints import Bool, Check, Integer, Options
from ._limits import MAX_LAYERS, MAX_WIDTH
from ._neural import _NeuralInpainter
from ._neural_params import NEURAL_CONSTRAINTS
from ._loop import Constant, Cosine, Optimisation, Schedule, seeded
from .nets import pixel_blend
from .nets.pixel_blend import PixelBlendNet
from .nets.prior_unet import PriorUNet

__all__ = ["ARCHS", "PriorUNetInpainter"]

#: ``"pixel"``: per-pixel MLP on candidates and gap lengths (the shipped recipe);
#: ``"unet"``: U-Net at 1/``factor`` resolution on candidates and masks.
ARCHS = ("pixel", "unet")

#: Class attributes of PriorUNetInpainter (its recipe), not parameters: nothing to check.
_FIXED_BY_RECIPE = ("depth", "input_mask", "depth_scale", "hole_weight", "tv_weight", "max_depth")

class PriorUNetInpainter(_NeuralInpainter):
    """Learned blend of classical candidate fills + residual, CPU-sized.

    Parameters
    ----------
    arch : {"pixel", "unet"}, default "pixel"
        ``"pixel"``: :class:`~estimators.learned.nets.pixel_blend.PixelBlendNet`, an MLP per
        pixel on the candidates and the gap lengths to the nearest measurement in the
        four directions. ``"unet"``: :class:`~estimators.learned.nets.prior_unet.PriorUNet`.
    width : int, default 128
        Hidden units (pixel) or channels of the first level (unet).
    levels : int, default 3
        Hidden layers (pixel) or 2× downsamplings after the pixel-unshuffle (unet).
    factor : int, default 8
        unet only: pixel-unshuffle factor (the network runs at ``1/factor``). Training
        frames (or crops) must be at least ``factor * 2**levels`` px per side, and
        ``width * 2**levels`` at most 2048.
    candidates : tuple of str, default :data:`estimators.candidates.CANDIDATES` (any of ``AVAILABLE_CANDIDATES``)
        Classical fills given to the network.
    endpoints : bool, default False
        pixel only: also give the depth of the nearest measurement left, right, above
        and below (:func:`estimators.candidates.endpoint_values`), so the blend can tell a
        gap over one surface from one over a depth edge.
    relative : bool, default False
        pixel only: scale-free blend (see :class:`~estimators.learned.nets.pixel_blend.PixelBlendNet`):
        the network sees depths as log-ratios to the candidates' geometric mean, so
        its prediction scales exactly with the input depth.
    pixel_batches : int, default 8
        pixel only: the hole pixels of each batch of frames are shuffled and split into
        this many optimiser steps (the candidate fills are the expensive part of a step,
        so each batch of frames is used for several cheap updates).
    flip : bool, default True
        Random horizontal flips while training (p = 0.5).
    tta : bool, default True
        Average the prediction with that of the mirrored frame.
    lr, weight_decay, batch_size, epochs, max_steps, max_minutes, crop, protocol,
    validation_fraction, warm_start, device, amp, channels_last, compile, num_threads,
    num_workers, random_state, checkpoint_dir, checkpoint_every, keep_observed, verbose
        As in :class:`estimators.learned.UNetInpainter`. ``crop=None`` (whole frames) is
        the recommended setting: candidates of a crop differ from those of the frame.

    Attributes
    ----------
    model_ : PriorUNet
    history_, n_steps_, seed_, run_dir_
        As in :class:`estimators.learned.UNetInpainter`; ``step_loss`` is the hole MSE
        in m².
    model_params_ : dict
        As in :class:`estimators.learned.UNetInpainter`: here ``arch``, ``width``,
        ``levels``, ``candidates`` and ``endpoints``/``relative`` (pixel) or ``factor``
        (unet); changing one after fit makes ``predict`` and ``save`` raise.
    """

    _skip = True
    _depth_param = "levels"
    #: What ``history_["step_loss"]`` is, with its unit (the y axis of ``inpaintenv train``'s loss.png).
    loss_label = "training loss: hole mean squared error (m²)"
    # Fixed by the recipe (read by the shared parameter checks and checkpoint code):
    # the loss is L2 on the hole in metres, no TV term, no valid-pixel term.
    hole_weight = 1.0
    tv_weight = 0.0
    max_depth = 80.0
    input_mask = True
    depth_scale = "fixed"  # the classical candidates already carry the frame's level

    def __init__(
        self,
        *,
        arch: str = "pixel",
        width: int = 128,
        levels: int = 3,
        factor: int = 8,
        candidates: tuple[str, ...] = CANDIDATES,
        endpoints: bool = False,
        relative: bool = False,
        pixel_batches: int = 8,
        flip: bool = True,
        tta: bool = True,
        lr: float = 2e-3,
        weight_decay: float = 0.0,
        batch_size: int = 4,
        epochs: int = 1000,
        max_steps: int | None = 600,
        max_minutes: float | None = None,
        crop: tuple[int, int] | None = None,
        protocol: str = "rect-v1",
        validation_fraction: float | None = None,
        warm_start: Any = None,
        device: str = "auto",
        amp: bool | str = True,
        channels_last: bool = False,
        compile: bool | str | dict = False,
        num_threads: int | None = None,
        num_workers: int = 0,
        random_state: Any = None,
        checkpoint_dir: str | os.PathLike | None = None,
        checkpoint_every: int | None = None,
        keep_observed: bool = True,
        verbose: bool = False,
    ):
        self.arch = arch
        self.width = width
        self.levels = levels
        self.factor = factor
        self.candidates = candidates
        self.endpoints = endpoints
        self.relative = relative
        self.pixel_batches = pixel_batches
        self.flip = flip
        self.tta = tta
        self.lr = lr
        self.weight_decay = weight_decay
        self.batch_size = batch_size
        self.epochs = epochs
        self.max_steps = max_steps
        self.max_minutes = max_minutes
        self.crop = crop
        self.protocol = protocol
        self.validation_fraction = validation_fraction
        self.warm_start = warm_start
        self.device = device
        self.amp = amp
        self.channels_last = channels_last
        self.compile = compile
        self.num_threads = num_threads
        self.num_workers = num_workers
        self.random_state = random_state
        self.checkpoint_dir = checkpoint_dir
        self.checkpoint_every = checkpoint_every
        self.keep_observed = keep_observed
        self.verbose = verbose

    # The shared checks read ``depth``; here it is the number of levels.
    @property
    def depth(self) -> int:
        return self.levels

    _parameter_constraints = {
        **{k: v for k, v in NEURAL_CONSTRAINTS.items() if k not in _FIXED_BY_RECIPE},
        "arch": [Options(*ARCHS)],
        # The U-Net's sizes are bounded more tightly by _check_capacity.
        "width": [Integer(1, limit=MAX_WIDTH)],
        "levels": [Integer(1, limit=MAX_LAYERS)],
        "factor": [Integer(1)],
        "candidates": [Check(check_candidates)],
        "endpoints": [Bool()],
        "relative": [Bool()],
        "pixel_batches": [Integer(1)],
        "flip": [Bool()],
        "tta": [Bool()],
    }
    # It flips its own features on the CPU (_train_step): no sample augmentation, no device
    # sampling, and every parameter in the run folder's key.
    _run_key_defaults: dict[str, Any] = {}

    def _augmentation(self) -> None:
        return None

    def _sample_on_device(self, device: torch.device) -> bool:
        return False

    def _model_param_names(self) -> tuple[str, ...]:
        # max_depth, input_mask and depth_scale are fixed by the class, not parameters.
        names = ("arch", "width", "levels", "candidates")
        return names + (("endpoints", "relative") if self.arch == "pixel" else ("factor",))

    def _check_capacity(self) -> None:
        # Only the U-Net doubles channels per level; the pixel MLP is width × levels.
        if self.arch != "pixel":
            super()._check_capacity()

    def _downsampling(self) -> tuple[int, str]:
        if self.arch == "pixel":
            return 1, "arch='pixel'"
        need = int(self.factor) * 2 ** int(self.levels)
        return need, f"factor={self.factor}, levels={self.levels} (factor * 2**levels = {need} px)"

    @property
    def in_channels(self) -> int:
        """Network input channels: depth, hole, valid, one per candidate (+ 4 gap lengths)."""
        return 3 + len(self.candidates) + (len(GAP_CHANNELS) if self._gaps else 0) + (
            len(ENDPOINT_CHANNELS) if self._endpoints else 0
        )

    @property
    def _gaps(self) -> bool:
        return self.arch == "pixel"

    @property
    def _endpoints(self) -> bool:
        return self.arch == "pixel" and bool(self.endpoints)

    def _build_model(self, seed: int) -> PriorUNet | PixelBlendNet:
        if self.arch == "pixel":
            return seeded(lambda: PixelBlendNet(len(self.candidates), len(GAP_CHANNELS), int(self.width),
                                                int(self.levels), n_endpoints=len(ENDPOINT_CHANNELS) if self._endpoints
                                                else 0, relative=bool(self.relative)), seed)
        return seeded(lambda: PriorUNet(len(self.candidates), int(self.width), int(self.levels), int(self.factor)), seed)

    def _config_params(self) -> dict[str, Any]:
        params = super()._config_params()
        params["candidates"] = list(params["candidates"])
        return params

    # -- features ----------------------------------------------------------------------
    def _features(self, x: np.ndarray) -> torch.Tensor:
        """``(N, H, W)`` corrupted frames (NaN holes) -> ``(N, 3 + K, H, W)`` tensor."""
        names = tuple(self.candidates)
        n_workers = min(len(x), torch.get_num_threads())
        if n_workers <= 1:
            return torch.from_numpy(np.stack([prior_features(frame, names, self._gaps, self._endpoints) for frame in x]))
        # The fills are NumPy/OpenCV work that mostly releases the GIL: threads suffice.
        with ThreadPoolExecutor(n_workers) as pool:
            return torch.from_numpy(np.stack(list(pool.map(
                lambda f: prior_features(f, names, self._gaps, self._endpoints), x))))

    def _flip(self, x: torch.Tensor) -> torch.Tensor:
        """Mirror features left-right (the left and right gap lengths and endpoint depths swap roles)."""
        x = x.flip(-1)
        order = list(range(x.shape[1]))
        k = 3 + len(self.candidates)
        if self._gaps:
            order[k], order[k + 1] = k + 1, k
            k += len(GAP_CHANNELS)
        if self._endpoints:
            order[k], order[k + 1] = k + 1, k
        return x[:, order] if order != list(range(x.shape[1])) else x

    # -- training ----------------------------------------------------------------------
    def _train(self, dataset, seed: int, device: torch.device, shard=None) -> None:
        # Flip decisions come from their own stream, independent of masks and crops.
        self._flip_rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0xF11B]))
        try:
            super()._train(dataset, seed, device, shard)
        finally:
            del self._flip_rng

    def _rng_state(self) -> dict[str, Any] | None:
        # The flip and pixel-order stream advances every step: resuming must continue it.
        return self._flip_rng.bit_generator.state

    def _set_rng_state(self, state: dict[str, Any] | None) -> None:
        if state is None:  # a checkpoint without the stream: it restarts (not bit-identical)
            return
        try:
            self._flip_rng.bit_generator.state = state
        except (TypeError, ValueError, KeyError) as e:
            raise ckpt.CheckpointError(f"the training checkpoint's random state does not fit this run: {e}") from None

    def _schedule(self) -> Schedule:
        """Cosine decay of the learning rate over ``max_steps`` (5 % linear warm-up); constant without ``max_steps``."""
        total = self.max_steps * self._updates_per_step if self.max_steps else None
        return Cosine(self.lr, total) if total else Constant()

    @property
    def _updates_per_step(self) -> int:
        return int(self.pixel_batches) if self.arch == "pixel" else 1

    #: A batch without ground truth in its holes takes no update; a pixel batch may take fewer.
    _exact_updates = False

    def _train_step(self, model: torch.nn.Module, optimisation: Optimisation, gt: torch.Tensor, hole: torch.Tensor,
                    device: torch.device) -> float:
        corrupted = torch.where(hole, torch.nan, gt).numpy()
        x = self._features(corrupted)
        if self.flip and self._flip_rng.random() < 0.5:
            x, gt, hole = self._flip(x), gt.flip(-1), hole.flip(-1)
        x, gt, hole = x.to(device), gt.to(device), hole.to(device)
        if self.channels_last:
            x = x.contiguous(memory_format=torch.channels_last)
        mask = hole & (gt > 0)
        if not mask.any():  # no ground truth in any hole of this batch: nothing to learn
            return 0.0
        if self.arch == "unet":
            return self._update(optimisation, lambda: model(x)[mask], gt[mask])
        # Per-pixel model: gather the hole pixels once, then several updates on shuffles.
        pixels, target = x[:, 3:].permute(0, 2, 3, 1)[mask], gt[mask]
        order = torch.from_numpy(self._flip_rng.permutation(len(target))).to(device)
        losses = [
            self._update(optimisation, lambda idx=idx: model.blend(pixels[idx]), target[idx])
            for idx in order.tensor_split(min(self._updates_per_step, len(order)))
        ]
        return float(np.mean(losses))

    def _update(self, optimisation: Optimisation, predict: Any, target: torch.Tensor) -> float:
        """One optimiser update on the L2 loss (metres) between ``predict()`` and ``target``."""
        def loss() -> torch.Tensor:
            with optimisation.autocast:
                pred = predict()
            # L2 in metres on the hole: the benchmark's metric is hole RMSE.
            return (pred.float() - target).square().mean()

        return optimisation.update(loss)

    # -- prediction ----------------------------------------------------------------------
    def _forward(self, model: PriorUNet | PixelBlendNet, X: np.ndarray, device: torch.device) -> np.ndarray:
        model.eval()
        autocast, _ = self._autocast(device)
        out = np.empty(X.shape, dtype=np.float32)
        k = len(self.candidates)
        with torch.inference_mode():
            for start in range(0, len(X), self.batch_size):
                chunk = X[start:start + self.batch_size]
                x = self._features(chunk)
                if self.arch == "pixel":
                    pred = pixel_blend.fill_holes(model, x, flip_average=bool(self.tta), device=device,
                                                  autocast=autocast)
                else:
                    x = x.to(device)
                    if self.channels_last:
                        x = x.contiguous(memory_format=torch.channels_last)
                    with autocast:
                        pred = model(x).float()
                        if self.tta:
                            pred = 0.5 * (pred + model(self._flip(x)).float().flip(-1))
                    # Floor at half the smallest candidate: the residual can otherwise push a
                    # far pixel to ~0 m, which barely moves RMSE but explodes inverse-depth
                    # errors (sel set: hole iRMSE 123 -> 40 /km, hole RMSE unchanged).
                    pred = torch.maximum(pred, 0.5 * x[:, 3:3 + k].min(dim=1).values).cpu()
                out[start:start + len(chunk)] = pred.numpy()
        return out

    @classmethod
    def _from_config(cls, config: dict[str, Any], weights: dict[str, torch.Tensor], where: Any) -> PriorUNetInpainter:
        """The model a checkpoint describes (see :meth:`UNetInpainter.load`); ``candidates`` as a tuple."""
        est = super()._from_config(config, weights, where)
        est.candidates = tuple(est.candidates)
        return est


# The shared loader (estimators.learned.load) finds classes by name in this table.
