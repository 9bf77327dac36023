"""The study's learned inpainters as scikit-learn estimators: U-Net and autoencoder.

>>> from estimators.neural import UNetInpainter                      # doctest: +SKIP
>>> est = UNetInpainter(width=16, crop=(176, 416), epochs=5, random_state=0)
>>> est.fit(train_dataset).predict(corrupted)                         # metres

See ``docs/neural.md`` for the models, the loss, checkpoints and resuming, and
cross-validated search.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import os
from pathlib import Path
from typing import Any

import numpy as np
import torch
from tqdm.auto import tqdm

from inpaintenv.conventions import check_depth
from inpaintenv.data.base import DepthDataset, split_by_drive
from inpaintenv.masks import get_protocol
from inpaintenv.metrics import aggregate, frame_metrics

from . import _checkpoint as ckpt
from ._training import (
    OcclusionFrames,
    crop_shape,
    data_fingerprint,
    encode_input,
    epoch_order,
    frame_label,
    make_loader,
    torch_threads,
)
from .base import BaseInpainter
from .losses import inpainting_loss
from .nets import UNet

__all__ = ["AutoencoderInpainter", "CheckpointError", "UNetInpainter", "load_checkpoint"]

CheckpointError = ckpt.CheckpointError

#: Parameters that change nothing about the trained weights: left out of the run-directory
#: hash so that e.g. changing ``verbose`` still resumes the same run.
_RUN_INDEPENDENT = ("verbose", "num_workers", "num_threads", "checkpoint_dir", "checkpoint_every", "keep_observed")
_AMP_CHOICES = (True, False, "cpu-bf16")
_DEPTH_SCALES = ("fixed", "frame")
_COMPILE_MODES = ("default", "reduce-overhead", "max-autotune", "max-autotune-no-cudagraphs")
#: Accepted ``max_depth`` range (metres). Depths are divided by it: far outside this
#: range the network's inputs and targets overflow or vanish in float32 and training
#: fails with a NaN loss that says nothing about the cause.
_MAX_DEPTH_RANGE = (0.1, 1e5)
#: Most channels allowed at the deepest U-Net level (``width * 2**depth``). The U-Net
#: doubles its channels per level, so each extra level about quadruples the parameters:
#: 2048 (e.g. width=128, depth=4) is already ~100 M parameters, while width=4, depth=12
#: (16,384 channels) needs tens of GB and gets the process killed.
MAX_CHANNELS = 2048


class _NeuralInpainter(BaseInpainter):
    """Shared implementation; use :class:`UNetInpainter` or :class:`AutoencoderInpainter`.

    Parameters
    ----------
    width : int, default 32
        Channels of the first level; doubled at every level. ``width * 2**depth`` may
        not exceed :data:`MAX_CHANNELS` (2048).
    depth : int, default 4
        Number of 2× downsamplings (inputs are padded internally to a multiple of
        ``2**depth`` and cropped back). Training frames (or crops) must be at least
        ``2**depth`` pixels on each side.
    input_mask : bool, default False
        False: the study's input, the corrupted depth alone (0 inside holes, divided by
        ``max_depth``). True: add a hole-mask and a validity-mask channel, since a 0
        otherwise means both "hole" and "no LiDAR".
    depth_scale : {"fixed", "frame"}, default "fixed"
        How depth is scaled for the network. "fixed": divided by ``max_depth`` (the
        study). "frame": divided by the mean observed depth of each frame and the output
        multiplied back by it. The GroupNorm layers discard the absolute level of their
        input, so with "fixed" the network must relearn how far a scene is from the few
        pixels whose level survives; with "frame" it predicts depth relative to the
        frame's own level, and a scene twice as far gets a fill twice as far.
    hole_weight : float, default 2.0
        λ of the loss (L1 over valid pixels inside holes).
    tv_weight : float, default 0.01
        β of the loss (anisotropic total variation of the prediction).
    max_depth : float, default 80.0
        Depth normalisation in metres (inputs and targets are divided by it); must be
        in [0.1, 1e5].
    lr, weight_decay : float
        Adam's learning rate (1e-3) and weight decay (1e-6).
    batch_size : int, default 4
        Training batch; prediction uses the same size.
    epochs : int, default 10
        Passes over the training frames.
    max_steps : int or None
        Stop after this many optimiser steps in total (even mid-epoch).
    crop : (int, int) or None
        Train on random ``(h, w)`` crops (each side clipped to the frame) instead of
        whole frames -- the practical choice on CPU. Occlusions are drawn on the crop.
    protocol : str, default "rect-v1"
        Occlusion protocol; masks are redrawn for every sample and epoch.
    validation_fraction : float or None
        Hold out this fraction of drives (:func:`inpaintenv.data.split_by_drive`); after
        each epoch the hole RMSE on them is measured and the best epoch's weights are
        kept (the study's selection). Needs at least two drives.
    warm_start : str, path, fitted estimator, bool or None
        A path written by :meth:`save` or a fitted autoencoder (or any fitted neural
        inpainter with the same ``width``, ``depth`` and input channels): initialise
        the encoder from it (the study's fine-tuning). Under ``GridSearchCV`` pass a
        path: ``clone`` drops the fitted state of an estimator parameter. ``True``
        (scikit-learn's meaning): start from this estimator's own previous fit, all
        weights (fresh optimiser). ``None``/``False``: random initialisation.
    device : {"auto", "cpu", "cuda", "cuda:N", "mps"}
        "auto" picks CUDA when available. Other torch device types (e.g. "meta") are
        rejected at fit/predict with a ValueError.
    amp : {True, False, "cpu-bf16"}, default True
        Mixed precision. True: autocast (bf16 where supported, else fp16 with gradient
        scaling) on CUDA only; False: float32 everywhere; "cpu-bf16": also bf16
        autocast on CPU.
    channels_last : bool, default False
        Use the channels-last memory format (can be faster on CPU/GPU; see benchmarks).
    compile : bool, str or dict, default False
        Run the network through ``torch.compile`` for training steps and prediction.
        True: default settings; a string: that ``mode`` (e.g. ``"max-autotune"``); a
        dict: keyword arguments of ``torch.compile`` (e.g. ``{"backend": "aot_eager"}``).
        The first step of each input shape pays the compilation (tens of seconds on
        CPU); see docs/performance.md for when it pays back. Weights and checkpoints
        are those of the plain module, so a compiled fit loads without compiling.
    num_threads : int or None
        ``torch.set_num_threads`` during fit/predict (restored after). None keeps the
        process setting (joblib workers already get ``cores // n_jobs``).
    num_workers : int, default 0
        DataLoader worker processes (each runs one torch thread).
    random_state : int or None
        Seeds weights, crops, masks and order. None draws a fresh seed per fit.
    checkpoint_dir : str, path or None
        Write training checkpoints under ``checkpoint_dir/<Class>-<hash>/`` (hash of the
        parameters and the training data) and resume from its ``last`` checkpoint when
        fit is called again with the same parameters and data.
    checkpoint_every : int or None
        Also checkpoint every this many steps (always at the end of each epoch).
    keep_observed : bool, default True
        Return measured input pixels unchanged.
    verbose : bool, default False
        Progress bar with the running loss.

    Attributes
    ----------
    model_ : UNet
        The trained network (on CPU after fit/load; moved to ``device`` to predict).
    history_ : dict
        ``step_loss`` (per step), ``epoch_loss`` (mean per epoch), ``val_hole_rmse``
        (per epoch, metres, empty without validation), ``best_epoch``.
    n_steps_ : int
        Optimiser steps taken.
    seed_ : int
        The seed actually used.
    run_dir_ : pathlib.Path or None
        This fit's checkpoint directory.
    model_params_ : dict
        The values at fit (or load) of the parameters the weights depend on (``width``,
        ``depth``, ``input_mask``, ``depth_scale``, ``max_depth``). ``predict`` and
        ``save`` raise ``ValueError`` if one was changed since; training-only
        (``lr``, ``max_steps``, ...) and prediction-time parameters (``batch_size``,
        ``device``, ``num_threads``, ``keep_observed``, ...) can be changed freely.
    """

    _skip: bool = True
    #: Name of the parameter that sets the number of downsamplings (read by messages).
    _depth_param: str = "depth"

    def __init__(
        self,
        *,
        width: int = 32,
        depth: int = 4,
        input_mask: bool = False,
        depth_scale: str = "fixed",
        hole_weight: float = 2.0,
        tv_weight: float = 0.01,
        max_depth: float = 80.0,
        lr: float = 1e-3,
        weight_decay: float = 1e-6,
        batch_size: int = 4,
        epochs: int = 10,
        max_steps: int | None = None,
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
        random_state: int | None = None,
        checkpoint_dir: str | os.PathLike | None = None,
        checkpoint_every: int | None = None,
        keep_observed: bool = True,
        verbose: bool = False,
    ):
        self.width = width
        self.depth = depth
        self.input_mask = input_mask
        self.depth_scale = depth_scale
        self.hole_weight = hole_weight
        self.tv_weight = tv_weight
        self.max_depth = max_depth
        self.lr = lr
        self.weight_decay = weight_decay
        self.batch_size = batch_size
        self.epochs = epochs
        self.max_steps = max_steps
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

    # -- parameters ----------------------------------------------------------------
    def _check_params(self) -> None:
        def int_at_least(name: str, low: int, optional: bool = False) -> None:
            v = getattr(self, name)
            if optional and v is None:
                return
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < low:
                raise ValueError(f"{name} must be an integer >= {low}{' or None' if optional else ''}, got {v!r}")

        def positive(name: str, allow_zero: bool = False) -> None:
            v = getattr(self, name)
            ok = isinstance(v, (int, float, np.number)) and not isinstance(v, bool) and math.isfinite(v)
            if not ok or v < 0 or (v == 0 and not allow_zero):
                raise ValueError(f"{name} must be a finite number {'>=' if allow_zero else '>'} 0, got {v!r}")

        int_at_least("width", 1)
        int_at_least("depth", 1)
        int_at_least("batch_size", 1)
        int_at_least("epochs", 1)
        int_at_least("max_steps", 1, optional=True)
        int_at_least("num_threads", 1, optional=True)
        int_at_least("num_workers", 0)
        int_at_least("checkpoint_every", 1, optional=True)
        for name in ("max_depth", "lr"):
            positive(name)
        low, high = _MAX_DEPTH_RANGE
        if not low <= self.max_depth <= high:
            raise ValueError(
                f"max_depth is the depth normalisation range in metres and must be in "
                f"[{low:g}, {high:g}] (the study uses 80), got {self.max_depth!r}"
            )
        for name in ("hole_weight", "tv_weight", "weight_decay"):
            positive(name, allow_zero=True)
        if self.crop is not None:
            c = self.crop
            if not (isinstance(c, (tuple, list)) and len(c) == 2 and all(
                isinstance(v, (int, np.integer)) and not isinstance(v, bool) and v >= 1 for v in c
            )):
                raise ValueError(f"crop must be None or a pair of positive integers (h, w), got {c!r}")
        if self.validation_fraction is not None and not (
            isinstance(self.validation_fraction, float) and 0.0 < self.validation_fraction < 1.0
        ):
            raise ValueError(f"validation_fraction must be None or a float in (0, 1), got {self.validation_fraction!r}")
        if self.amp not in _AMP_CHOICES or isinstance(self.amp, (int, float)) and not isinstance(self.amp, bool):
            raise ValueError(f"amp must be one of {_AMP_CHOICES}, got {self.amp!r}")
        if self.random_state is not None and (
            isinstance(self.random_state, bool) or not isinstance(self.random_state, (int, np.integer))
            or self.random_state < 0
        ):
            raise ValueError(f"random_state must be a non-negative int or None, got {self.random_state!r}")
        if not (
            isinstance(self.compile, (bool, np.bool_, dict))
            or (isinstance(self.compile, str) and self.compile in _COMPILE_MODES)
        ):
            raise ValueError(
                f"compile must be True, False, a dict of torch.compile arguments or one of "
                f"{_COMPILE_MODES}, got {self.compile!r}"
            )
        self._check_capacity()
        if self.depth_scale not in _DEPTH_SCALES:
            raise ValueError(f"depth_scale must be one of {_DEPTH_SCALES}, got {self.depth_scale!r}")
        get_protocol(self.protocol)  # KeyError listing the known protocols

    def _model_param_names(self) -> tuple[str, ...]:
        """Parameters the trained weights depend on: the architecture and how depth is
        scaled into and out of the network (not training-only or prediction-time ones)."""
        return ("width", "depth", "input_mask", "depth_scale", "max_depth")

    def _model_params(self) -> dict[str, Any]:
        """Current values of :meth:`_model_param_names`, as plain comparable values."""
        return {name: _plain(getattr(self, name)) for name in self._model_param_names()}

    def _check_model_params(self, hint: str = "refit or set it back") -> None:
        """Raise if a parameter the fitted weights depend on changed since fit/load.

        Without this, ``set_params(max_depth=20)`` after fit would silently rescale the
        output and ``set_params(width=8)`` would run the width-4 model while
        ``get_params`` says 8.
        """
        fitted = getattr(self, "model_params_", None)
        if fitted is None:  # pickled by a version that did not record them
            return
        for name, value in fitted.items():
            current = _plain(getattr(self, name, None))
            if current != value:
                raise ValueError(
                    f"{name}={current!r} differs from the {value!r} this model was trained with; {hint}"
                )

    def _check_capacity(self) -> None:
        """Refuse networks far larger than any sensible use (channels double per level)."""
        # Compare without computing 2**depth for an absurd depth.
        if self.depth > MAX_CHANNELS.bit_length() or int(self.width) << int(self.depth) > MAX_CHANNELS:
            d = self._depth_param
            count = str(int(self.width) << int(self.depth)) if self.depth <= 64 else "astronomically many"
            raise ValueError(
                f"width={self.width}, {d}={self.depth} gives {count} channels at the deepest level "
                f"(width * 2**{d}), more than the {MAX_CHANNELS} allowed (channels double per level, "
                f"so parameters about quadruple); lower {d} or width"
            )

    def _downsampling(self) -> tuple[int, str]:
        """Total downsampling factor of the network and the parameters that set it."""
        need = 2 ** int(self.depth)
        return need, f"depth={self.depth} (2**depth = {need} px)"

    def _check_frame_size(self, frame_shape: tuple[int, int]) -> None:
        """Refuse training samples smaller than the network's total downsampling.

        The network pads any input to a multiple of it, so this is not about crashing:
        on smaller samples the deepest levels see nothing but padding.
        """
        ch, cw = crop_shape(frame_shape, self.crop)
        need, what = self._downsampling()
        if min(ch, cw) < need:
            kind = "crops" if self.crop is not None else "frames"
            raise ValueError(
                f"{what} needs training {kind} of at least {need} px per side, got {ch}x{cw}; "
                f"lower it or train on larger {kind}"
            )

    def _device(self) -> torch.device:
        """The torch device to fit/predict on; a clear ValueError for anything unusable.

        Accepted: "auto", "cpu", "cuda", "cuda:N" (N < the number of GPUs) and "mps"
        where available. Other torch device types ("meta", "xla", ...) would only fail
        later, deep inside autocast or a kernel.
        """
        choices = "'auto', 'cpu', 'cuda', 'cuda:N' or 'mps'"
        if self.device == "auto":
            return torch.device("cuda" if torch.cuda.is_available() else "cpu")
        if not isinstance(self.device, (str, torch.device)):
            raise TypeError(f"device must be one of {choices}, got {self.device!r}")
        try:
            dev = torch.device(self.device)
        except (RuntimeError, TypeError, ValueError):
            raise ValueError(f"device must be one of {choices}, got {self.device!r}") from None
        if dev.type == "cpu":
            return dev
        if dev.type == "cuda":
            if not torch.cuda.is_available():
                raise ValueError(f"device={self.device!r} but no CUDA device is available; use device='auto' or 'cpu'")
            if dev.index is not None and dev.index >= torch.cuda.device_count():
                raise ValueError(
                    f"device={self.device!r} but only {torch.cuda.device_count()} CUDA device(s) are visible"
                )
            return dev
        if dev.type == "mps":
            if not torch.backends.mps.is_available():
                raise ValueError(f"device={self.device!r} but MPS is not available here; use device='auto' or 'cpu'")
            return dev
        raise ValueError(f"device must be one of {choices}, got {self.device!r} (device type {dev.type!r} is not supported)")

    def _autocast(self, device: torch.device) -> tuple[Any, bool]:
        """Autocast context for ``device`` and whether fp16 gradient scaling is needed."""
        # As documented: autocast on CUDA, and on CPU only with "cpu-bf16"; never on
        # other devices (MPS), whose autocast support varies across torch versions.
        if self.amp is False or device.type not in ("cpu", "cuda") or (device.type == "cpu" and self.amp != "cpu-bf16"):
            return contextlib.nullcontext(), False
        if device.type == "cuda" and self.amp is True and not torch.cuda.is_bf16_supported():
            return torch.autocast("cuda", dtype=torch.float16), True
        return torch.autocast(device.type, dtype=torch.bfloat16), False

    def _input_scale(self, observed: torch.Tensor) -> torch.Tensor | float:
        """Metres per network unit: ``max_depth``, or each frame's mean observed depth.

        ``observed`` is ``(N, H, W)`` metres with 0 in holes and where unmeasured; the
        frame scale is returned as ``(N, 1, 1)`` so it broadcasts over pixels. A frame
        with nothing observed falls back to ``max_depth``; the floor of 1 m keeps a
        frame of a few very near points from blowing up the input.
        """
        if self.depth_scale == "fixed":
            return self.max_depth
        valid = observed > 0
        count = valid.sum(dim=(1, 2), keepdim=True)
        mean = observed.sum(dim=(1, 2), keepdim=True) / count.clamp(min=1)
        return torch.where(count > 0, mean.clamp(min=1.0), torch.full_like(mean, self.max_depth))

    @property
    def in_channels(self) -> int:
        """Network input channels: 1 (depth) or 3 (depth, hole mask, validity mask)."""
        return 3 if self.input_mask else 1

    def _build_model(self, seed: int) -> UNet:
        # Seed the initial weights without touching the caller's global torch RNG.
        with torch.random.fork_rng(devices=[]):
            torch.manual_seed(seed)
            return UNet(self.in_channels, int(self.width), int(self.depth), skip=self._skip)

    # -- run directory / hashing ---------------------------------------------------
    def _config_params(self) -> dict[str, Any]:
        """Parameters as JSON-able values (warm_start estimators become a weight hash)."""
        params = self.get_params(deep=False)
        ws = params["warm_start"]
        if isinstance(ws, bool):
            params["warm_start"] = ws
            if ws and hasattr(self, "model_"):
                params["warm_start"] = f"<previous fit sha256:{_weights_hash(self)}>"
        elif isinstance(ws, _NeuralInpainter):
            params["warm_start"] = f"<{type(ws).__name__} weights sha256:{_weights_hash(ws)}>" if hasattr(ws, "model_") else f"<unfitted {type(ws).__name__}>"
        elif ws is not None:
            params["warm_start"] = str(ws)
        if params["crop"] is not None:
            params["crop"] = [int(v) for v in params["crop"]]
        if params["checkpoint_dir"] is not None:
            params["checkpoint_dir"] = str(params["checkpoint_dir"])
        return {k: (v.item() if isinstance(v, np.generic) else v) for k, v in params.items()}

    def _run_dir(self, dataset: DepthDataset, seed: int) -> Path | None:
        if self.checkpoint_dir is None:
            return None
        params = {k: v for k, v in self._config_params().items() if k not in _RUN_INDEPENDENT}
        key = json.dumps({"params": params, "seed": seed, "data": data_fingerprint(dataset)}, sort_keys=True)
        digest = hashlib.sha256(key.encode()).hexdigest()[:16]
        return Path(self.checkpoint_dir) / f"{type(self).__name__}-{digest}"

    # -- fitting -------------------------------------------------------------------
    def _fit(self, dataset: DepthDataset) -> None:
        self._check_params()
        check_depth(dataset[0], name="X[0]")
        self._check_frame_size(dataset.frame_shape)
        seed = int(self.random_state) if self.random_state is not None else int(
            np.random.SeedSequence().generate_state(1)[0]
        )
        device = self._device()
        with torch_threads(self.num_threads) as n_threads:
            self.n_threads_ = n_threads
            self._train(dataset, seed, device)
        self.seed_ = seed
        self.model_params_ = self._model_params()

    def _train(self, dataset: DepthDataset, seed: int, device: torch.device) -> None:
        if self.validation_fraction is not None:
            train_ds, val_ds = split_by_drive(dataset, self.validation_fraction, seed=seed)
        else:
            train_ds, val_ds = dataset, None
        protocol = get_protocol(self.protocol)
        model = self._build_model(seed)
        if self.warm_start is True:
            # scikit-learn's meaning: continue from this estimator's previous fit, if any.
            if hasattr(self, "model_"):
                _copy_encoder(self.model_, model)
                model.load_state_dict(self.model_.state_dict())
        elif self.warm_start is not None and self.warm_start is not False:
            _copy_encoder(self._warm_start_model(), model)
        optimizer, autocast, scaler = self._prepare_training(model, device)
        step_model = self._compiled(model)

        n_batches = math.ceil(len(train_ds) / self.batch_size)
        total = self.epochs * n_batches if self.max_steps is None else min(self.max_steps, self.epochs * n_batches)
        progress: dict[str, Any] = {
            "epoch": 0, "batch": 0, "step": 0, "finished": False,
            "history": {"step_loss": [], "epoch_loss": [], "val_hole_rmse": [], "best_epoch": None},
        }
        best_state: dict[str, torch.Tensor] | None = None
        run_dir = self._run_dir(dataset, seed)
        self.run_dir_ = run_dir
        config = {"class": type(self).__name__, "params": self._config_params(), "seed": seed,
                  "torch_threads": torch.get_num_threads()}
        if run_dir is not None:
            resumed = self._resume(run_dir, model, optimizer, device)
            if resumed is not None:
                progress, best_state = resumed

        hist = progress["history"]
        data = OcclusionFrames(train_ds, protocol, self.crop, seed)
        pin = device.type == "cuda"

        def save(*, new_best: bool = False) -> None:
            if run_dir is None:
                return
            tensors, meta = ckpt.flatten_optimizer_state(optimizer.state_dict())
            ckpt.write_run_checkpoint(
                run_dir, progress["step"], {**config, "fitted": _fitted_summary(progress)},
                _cpu_state(model), {**progress, "optimizer": meta}, tensors, best_is_current=new_best,
            )

        bar = tqdm(total=total, initial=progress["step"], disable=not self.verbose, desc=type(self).__name__, leave=False)
        running = None
        try:
            while not progress["finished"]:
                epoch = progress["epoch"]
                data.epoch = epoch
                order = epoch_order(len(train_ds), seed, epoch)[progress["batch"] * self.batch_size:]
                stopped = False
                model.train()
                for gt, hole in make_loader(data, order, self.batch_size, self.num_workers, pin):
                    loss = self._train_step(step_model, optimizer, scaler, autocast, gt, hole, device)
                    hist["step_loss"].append(loss)
                    progress["step"] += 1
                    progress["batch"] += 1
                    running = loss if running is None else 0.9 * running + 0.1 * loss
                    bar.update(1)
                    bar.set_postfix(loss=f"{running:.4f}", epoch=epoch)
                    if self.max_steps is not None and progress["step"] >= self.max_steps:
                        stopped = True
                        break
                    if self.checkpoint_every and progress["step"] % self.checkpoint_every == 0:
                        save()
                # End of an epoch (or of a run stopped by max_steps mid-epoch).
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
                        best_state = _cpu_state(model, clone=True)
                        new_best = True
                    model.train()
                progress["epoch"] = epoch + 1
                progress["batch"] = 0
                progress["epoch_start_step"] = progress["step"]
                progress["finished"] = stopped or progress["epoch"] >= self.epochs
                save(new_best=new_best)
        finally:
            bar.close()

        if best_state is not None:
            model.load_state_dict(best_state)
        self.model_ = model.to("cpu", memory_format=torch.contiguous_format).eval()
        self.history_ = hist
        self.n_steps_ = progress["step"]

    def _prepare_training(self, model: torch.nn.Module, device: torch.device) -> tuple[Any, Any, Any]:
        """Move ``model`` to ``device`` (channels-last if asked) and build the Adam optimizer,
        the autocast context and the CUDA gradient scaler (None when not needed).

        Shared by :meth:`_train` and ``estimators.distributed`` so both train alike.
        """
        model.to(device)
        if self.channels_last:
            model.to(memory_format=torch.channels_last)
        optimizer = torch.optim.Adam(model.parameters(), lr=self.lr, weight_decay=self.weight_decay)
        autocast, needs_scaler = self._autocast(device)
        scaler = torch.amp.GradScaler("cuda") if needs_scaler else None
        return optimizer, autocast, scaler

    def _compiled(self, model: torch.nn.Module) -> torch.nn.Module:
        """``model`` through ``torch.compile`` as the ``compile`` parameter asks, else itself.

        The compiled wrapper shares the module's parameters, so optimiser, checkpoints
        and ``train()``/``eval()`` keep working on the plain module.
        """
        if isinstance(self.compile, dict):
            kwargs = dict(self.compile)
        elif isinstance(self.compile, str):
            kwargs = {"mode": self.compile}
        elif self.compile:  # True or numpy.True_ (the parameter check accepts both)
            kwargs = {}
        else:
            return model
        return torch.compile(model, **kwargs)

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
        if not torch.isfinite(loss):
            raise FloatingPointError(
                f"training loss became {loss.item()} at step; lower lr or disable amp"
            )
        if scaler is not None:
            scaler.scale(loss).backward()
            scaler.step(optimizer)
            scaler.update()
        else:
            loss.backward()
            optimizer.step()
        return float(loss.detach())

    def _resume(self, run_dir: Path, model: UNet, optimizer, device) -> tuple[dict, dict | None] | None:
        state = ckpt.read_run_state(run_dir)
        if state is None:
            return None
        _, weights, progress, optim = ckpt.read_checkpoint(run_dir / state["last"], training=True)
        model.load_state_dict(weights)
        meta = progress.pop("optimizer")
        optimizer.load_state_dict(ckpt.unflatten_optimizer_state(optim, meta))
        for k in ("optimizer_sha256", "weights_sha256"):
            progress.pop(k, None)
        best = None
        if state.get("best"):
            _, best, _, _ = ckpt.read_checkpoint(run_dir / state["best"])
        return progress, best

    def _warm_start_model(self) -> UNet:
        ws = self.warm_start
        if isinstance(ws, _NeuralInpainter):
            if not hasattr(ws, "model_"):
                raise ValueError(
                    "warm_start estimator is not fitted (note: clone(), as in GridSearchCV, "
                    "drops fitted state; pass a path written by .save() instead)"
                )
            return ws.model_
        if isinstance(ws, (str, os.PathLike)):
            return _NeuralInpainter.load(ws).model_
        raise TypeError(f"warm_start must be None, a path, or a fitted neural inpainter, got {type(ws).__name__}")

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
            parts.append(frame_metrics(pred, gt, hole, max_depth=self.max_depth))
        table = aggregate({k: np.concatenate([np.atleast_1d(p[k]) for p in parts]) for k in parts[0]})
        return float(table["hole_rmse"])

    # -- prediction ------------------------------------------------------------------
    def _forward(self, model: UNet, X: np.ndarray, device: torch.device) -> np.ndarray:
        """Run ``model`` on an ``(N, H, W)`` batch with NaN holes; metres out."""
        model.eval()
        autocast, _ = self._autocast(device)
        out = np.empty(X.shape, dtype=np.float32)
        # On CPU, frames go one by one: batched oneDNN convolutions round differently per
        # batch composition, and a frame's prediction must not depend on its neighbours.
        # GPUs get real batches (that is where batching pays).
        step = self.batch_size if device.type == "cuda" else 1
        with torch.inference_mode():
            for start in range(0, len(X), step):
                # A copy: the input may be read-only (memmap) and must never be modified.
                chunk = torch.from_numpy(np.array(X[start:start + step], dtype=np.float32))
                hole = torch.isnan(chunk)
                depth = torch.nan_to_num(chunk, nan=0.0)
                scale = self._input_scale(depth)
                x = encode_input(depth, hole, scale, self.input_mask).to(device)
                if self.channels_last:
                    x = x.contiguous(memory_format=torch.channels_last)
                with autocast:
                    pred = model(x)[:, 0]
                out[start:start + len(chunk)] = (pred.float().cpu() * scale).numpy()
        return out

    def _predict_batch(self, X: np.ndarray) -> np.ndarray:
        self._check_params()
        self._check_model_params()
        device = self._device()
        with torch_threads(self.num_threads):
            model = self.model_.to(device)
            if self.channels_last:
                model = model.to(memory_format=torch.channels_last)
            try:
                return self._forward(self._compiled(model), X, device)
            finally:
                self.model_ = model.to("cpu", memory_format=torch.contiguous_format)

    # -- persistence -------------------------------------------------------------------
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
        }
        return ckpt.write_checkpoint(path, config, _cpu_state(self.model_))

    @classmethod
    def load(cls, path: str | os.PathLike) -> _NeuralInpainter:
        """Load a model written by :meth:`save`, or the best (else last) model of a run dir.

        Raises
        ------
        CheckpointError
            If the checkpoint is missing, truncated, corrupt, or of another class.
        """
        path = Path(path)
        state = ckpt.read_run_state(path) if path.is_dir() else None
        if state is not None:
            path = path / (state.get("best") or state["last"])
        config, weights, _, _ = ckpt.read_checkpoint(path)
        klass = _CLASSES.get(config.get("class"))
        if klass is None or not issubclass(klass, cls):
            raise CheckpointError(f"{path} holds a {config.get('class')!r}, not a {cls.__name__}")
        params = dict(config["params"])
        if params.get("crop") is not None:
            params["crop"] = tuple(params["crop"])
        if isinstance(params.get("warm_start"), str) and params["warm_start"].startswith("<"):
            params["warm_start"] = None  # an in-memory estimator cannot be restored; weights are
        try:
            est = klass(**params)
        except TypeError as e:
            raise CheckpointError(f"{path} has parameters this version does not know: {e}") from None
        model = est._build_model(0)
        try:
            model.load_state_dict(weights)
        except RuntimeError as e:
            raise CheckpointError(f"{path}: weights do not fit the saved architecture: {e}") from None
        est.model_ = model.eval()
        fitted = config.get("fitted") or {}
        est.history_ = fitted.get("history_") or progress_history(fitted)
        est.n_steps_ = int(fitted.get("n_steps_", fitted.get("step", 0)) or 0)
        est.seed_ = config.get("seed")
        est.model_params_ = est._model_params()
        est.is_fitted_ = True
        return est


def _plain(value: Any) -> Any:
    """``value`` with NumPy scalars as Python ones and lists as tuples, for comparison."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, (list, tuple)):
        return tuple(_plain(v) for v in value)
    return value


def progress_history(fitted: dict[str, Any]) -> dict[str, Any]:
    """History stored in a training-run checkpoint summary (or an empty one)."""
    return fitted.get("history") or {"step_loss": [], "epoch_loss": [], "val_hole_rmse": [], "best_epoch": None}


def _fitted_summary(progress: dict[str, Any]) -> dict[str, Any]:
    return {"n_steps_": progress["step"], "history_": progress["history"]}


def _cpu_state(model: torch.nn.Module, clone: bool = False) -> dict[str, torch.Tensor]:
    state = {k: v.detach().to("cpu").contiguous() for k, v in model.state_dict().items()}
    return {k: v.clone() for k, v in state.items()} if clone else state


def _weights_hash(est: _NeuralInpainter) -> str:
    h = hashlib.sha256()
    for k, v in sorted(_cpu_state(est.model_).items()):
        h.update(k.encode())
        h.update(v.float().numpy().tobytes())
    return h.hexdigest()[:16]


def _copy_encoder(source: UNet, target: UNet) -> None:
    """Copy ``source.encoder`` into ``target.encoder``; shapes must agree."""
    src, dst = source.encoder.state_dict(), target.encoder.state_dict()
    mismatch = [k for k in dst if k not in src or src[k].shape != dst[k].shape]
    if mismatch:
        raise ValueError(
            "warm_start encoder does not match this model (width/depth/input_mask must be "
            f"equal): source in_channels={source.in_channels}, width={source.width}, depth={source.depth}; "
            f"target in_channels={target.in_channels}, width={target.width}, depth={target.depth}"
        )
    target.encoder.load_state_dict({k: src[k].to("cpu") for k in dst})


class UNetInpainter(_NeuralInpainter):
    __doc__ = (_NeuralInpainter.__doc__ or "").replace(
        "Shared implementation; use :class:`UNetInpainter` or :class:`AutoencoderInpainter`.",
        "The study's U-Net inpainter: encoder-decoder with skip connections, trained with\n"
        "    L1 (valid) + λ·L1 (hole) + β·TV on occlusions redrawn every epoch.",
    )
    _skip = True


class AutoencoderInpainter(_NeuralInpainter):
    __doc__ = (_NeuralInpainter.__doc__ or "").replace(
        "Shared implementation; use :class:`UNetInpainter` or :class:`AutoencoderInpainter`.",
        "The study's autoencoder ablation: the U-Net with every skip connection removed.\n"
        "    A fitted autoencoder can warm-start a U-Net's encoder (``warm_start``).",
    )
    _skip = False


_CLASSES: dict[str, type[_NeuralInpainter]] = {
    "UNetInpainter": UNetInpainter,
    "AutoencoderInpainter": AutoencoderInpainter,
}


def load_checkpoint(path: str | os.PathLike) -> _NeuralInpainter:
    """Load any saved neural inpainter (its class is read from the checkpoint).

    Parameters
    ----------
    path : path-like
        A model folder written by ``save`` or a training run folder.

    Raises
    ------
    CheckpointError
        If the checkpoint is missing, corrupt, or of an unknown class.
    """
    import importlib

    # Classes defined elsewhere register themselves in _CLASSES on import.
    importlib.import_module("estimators.prior")
    return _NeuralInpainter.load(path)
