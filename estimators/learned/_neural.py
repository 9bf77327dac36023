"""The study's learned inpainters as scikit-learn estimators: U-Net and autoencoder.

>>> from estimators.learned import UNetInpainter                      # doctest: +SKIP
>>> est = UNetInpainter(width=16, crop=(176, 416), epochs=5, random_state=0)
>>> est.fit(train_dataset).predict(corrupted)                         # metres

See ``docs/neural.md`` for the models, the loss, checkpoints and resuming, and
cross-validated search.

The estimator holds its parameters (``__init__``, documented below), their checks and
prediction, and the config hooks of ``save`` / ``load``; the parameter table and what each
value means for torch are in ``_neural_params.py``, the training loop in ``_training.py``
(:class:`~estimators.learned._training.TrainingMixin`) and ``save`` / ``load`` in
``_persistence.py`` (:class:`~estimators.learned._persistence.PersistenceMixin`).
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np
import torch
from sklearn.exceptions import NotFittedError

from inpaintenv.exceptions import InvalidInputError

from ..base import BaseInpainter

from . import _checkpoint as ckpt
from .._constraints import ConstrainedParams
from ._limits import check_parameter_count
from ._loop import seeded
from ._neural_params import (MAX_CHANNELS, STUDY_CONSTRAINTS, autocast, compiled, config_params, input_scale, plain,
                             resolve_device)
from ._output import bound_output
from ._persistence import PersistenceMixin
from ._training import Augmentation, TrainingMixin, crop_shape, encode_input, torch_threads
from .nets import UNet

__all__ = ["AutoencoderInpainter", "CheckpointError", "UNetInpainter"]

CheckpointError = ckpt.CheckpointError


class _NeuralInpainter(ConstrainedParams, TrainingMixin, PersistenceMixin, BaseInpainter):
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
    max_minutes : float or None
        Wall-clock budget of one ``fit`` call, in minutes (None: no limit): training stops
        after the step during which it ran out, writes its checkpoint and records the
        stop in ``history_["budget_stop"]``. A later ``fit`` with the same parameters and
        ``checkpoint_dir`` resumes from there with a whole new budget (each call counts
        only its own time; ``max_minutes`` is left out of the run folder's key).
    crop : (int, int) or None
        Train on random ``(h, w)`` crops (each side clipped to the frame) instead of
        whole frames -- the practical choice on CPU. Occlusions are drawn on the crop.
    flip : bool, default False
        Mirror each training sample left-right with probability 0.5 (its depth and hole
        together). The decision, like the crop and the occlusion, is drawn from
        ``(seed, epoch, index)`` (a stream of its own: turning flips on leaves every crop
        and occlusion as it was), so it is the same on any device, with any
        ``num_workers`` and after a resume.
    depth_jitter : float in (1, 2] or None, default None
        Multiply each training sample's depth by a factor drawn log-uniformly from
        ``[1/depth_jitter, depth_jitter]`` (from the same stream as ``flip``): the scene
        nearer or farther. None: no scaling.
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
        Use the channels-last memory format (can be faster on CPU/GPU; see perf/).
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
        DataLoader worker processes (each runs one torch thread), kept for the whole fit
        (``persistent_workers``); batches are pinned when training on CUDA. Any number
        gives the same samples.
    sample_device : {"cpu", "auto", "train"}, default "cpu"
        Where training batches are cropped, occluded and augmented. "cpu": in the
        loader (its workers, if any). "train": on the device the network trains on,
        from whole frames the loader decodes; the random choices are drawn on the CPU
        as before, so the samples are the same bit for bit (``rect-v1`` rectangles are
        rasterised on the device, other protocols' masks drawn on the CPU and sent).
        "auto": "train" when training on CUDA, else "cpu".
    random_state : int, numpy RandomState or Generator, or None
        Seeds weights, crops, masks and order. None draws a fresh seed per fit; a
        RandomState or Generator gives its next number (the seed used is ``seed_``).
    checkpoint_dir : str, path or None
        Write training checkpoints under ``checkpoint_dir/<Class>-<hash>/`` (hash of the
        parameters and the training data) and resume from its ``last`` checkpoint when
        fit is called again with the same parameters and data.
    checkpoint_every : int or None
        Also checkpoint every this many steps (always at the end of each epoch).
    keep_observed : bool, default True
        Return measured input pixels unchanged.
    verbose : bool or int, default False
        Progress of ``fit`` when true or > 0 (as scikit-learn's ``verbose``): on a terminal a
        bar with the running loss and the time left, in a log one line per epoch.

    Attributes
    ----------
    model_ : UNet
        The trained network (on CPU after fit/load; moved to ``device`` to predict).
    history_ : dict
        ``step_loss`` (per step), ``epoch_loss`` (mean per epoch), ``val_hole_rmse``
        (per epoch, metres, empty without validation), ``best_epoch``; ``budget_stop``
        (``step``, ``minutes``, ``max_minutes``) only when ``max_minutes`` stopped the fit.
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
    #: What ``history_["step_loss"]`` is (the y axis of ``inpaintenv train``'s loss.png): the study's
    #: loss on depth divided by ``max_depth``, so without a unit.
    loss_label: str = "training loss: L1 + hole L1 + TV of depth / max_depth (no unit)"
    _parameter_constraints = STUDY_CONSTRAINTS
    # Left out of the run folder's key at their defaults, so a run folder keyed without
    # them resumes.
    _run_key_defaults = {"flip": False, "depth_jitter": None}

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
        max_minutes: float | None = None,
        crop: tuple[int, int] | None = None,
        flip: bool = False,
        depth_jitter: float | None = None,
        protocol: str = "rect-v1",
        validation_fraction: float | None = None,
        warm_start: Any = None,
        device: str = "auto",
        amp: bool | str = True,
        channels_last: bool = False,
        compile: bool | str | dict = False,
        num_threads: int | None = None,
        num_workers: int = 0,
        sample_device: str = "cpu",
        random_state: int | np.random.RandomState | np.random.Generator | None = None,
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
        self.max_minutes = max_minutes
        self.crop = crop
        self.flip = flip
        self.depth_jitter = depth_jitter
        self.protocol = protocol
        self.validation_fraction = validation_fraction
        self.warm_start = warm_start
        self.device = device
        self.amp = amp
        self.channels_last = channels_last
        self.compile = compile
        self.num_threads = num_threads
        self.num_workers = num_workers
        self.sample_device = sample_device
        self.random_state = random_state
        self.checkpoint_dir = checkpoint_dir
        self.checkpoint_every = checkpoint_every
        self.keep_observed = keep_observed
        self.verbose = verbose

    # -- parameters, checked and interpreted at fit / predict (their table: _neural_params.py) --
    def _check_param_relations(self) -> None:
        self._check_capacity()

    def _model_param_names(self) -> tuple[str, ...]:
        """Parameters the trained weights depend on: the architecture and how depth is
        scaled into and out of the network (not training-only or prediction-time ones)."""
        return ("width", "depth", "input_mask", "depth_scale", "max_depth")

    def _model_params(self) -> dict[str, Any]:
        """Current values of :meth:`_model_param_names`, as plain comparable values."""
        return {name: plain(getattr(self, name)) for name in self._model_param_names()}

    def _check_model_params(self, hint: str = "refit or set it back") -> None:
        """Raise if a parameter the fitted weights depend on changed since fit/load (else
        ``set_params(max_depth=20)`` would silently rescale the output)."""
        for name, value in (getattr(self, "model_params_", None) or {}).items():
            current = plain(getattr(self, name, None))
            if current != value:
                raise InvalidInputError(
                    f"{name}={current!r} differs from the {value!r} this model was trained with; {hint}")

    def _check_capacity(self) -> None:
        """Refuse networks far larger than any sensible use (channels double per level)."""
        # Compare without computing 2**depth for an absurd depth.
        if self.depth > MAX_CHANNELS.bit_length() or int(self.width) << int(self.depth) > MAX_CHANNELS:
            d = self._depth_param
            count = str(int(self.width) << int(self.depth)) if self.depth <= 64 else "astronomically many"
            raise InvalidInputError(
                f"width={self.width}, {d}={self.depth} gives {count} channels at the deepest level "
                f"(width * 2**{d}), more than the {MAX_CHANNELS} allowed (channels double per level, "
                f"so parameters about quadruple); lower {d} or width"
            )

    def _check_size(self) -> None:
        """Refuse a network of more than ``MAX_PARAMETERS`` (counted before it is built)."""
        sizes = ", ".join(f"{k}={getattr(self, k)!r}" for k in self._model_param_names() if k not in ("candidates",))
        check_parameter_count(lambda: self._build_model(0), sizes)

    def _downsampling(self) -> tuple[int, str]:
        """Total downsampling factor of the network and the parameters that set it."""
        need = 2 ** int(self.depth)
        return need, f"depth={self.depth} (2**depth = {need} px)"

    def _check_frame_size(self, frame_shape: tuple[int, int]) -> None:
        """Refuse training samples smaller than the network's total downsampling (the network
        pads any input to a multiple of it, and its deepest levels would see only padding)."""
        ch, cw = crop_shape(frame_shape, self.crop)
        need, what = self._downsampling()
        if min(ch, cw) < need:
            kind = "crops" if self.crop is not None else "frames"
            raise InvalidInputError(f"{what} needs training {kind} of at least {need} px per side, got {ch}x{cw}; "
                                    f"lower it or train on larger {kind}")

    def _device(self) -> torch.device:
        return resolve_device(self.device)

    def _autocast(self, device: torch.device) -> tuple[Any, bool]:
        return autocast(self.amp, device)

    def _input_scale(self, observed: torch.Tensor) -> torch.Tensor | float:
        return input_scale(observed, self.depth_scale, self.max_depth)

    def _compiled(self, model: torch.nn.Module) -> torch.nn.Module:
        return compiled(model, self.compile)

    def _config_params(self) -> dict[str, Any]:
        return config_params(self)

    @property
    def in_channels(self) -> int:
        """Network input channels: 1 (depth) or 3 (depth, hole mask, validity mask)."""
        return 3 if self.input_mask else 1

    def _build_model(self, seed: int) -> UNet:
        # Seed the initial weights without touching the caller's global torch RNG.
        return seeded(lambda: UNet(self.in_channels, int(self.width), int(self.depth), skip=self._skip), seed)

    def _augmentation(self) -> Augmentation:
        jitter = None if self.depth_jitter is None else float(self.depth_jitter)
        return Augmentation(flip=bool(self.flip), depth_jitter=jitter)

    def _sample_on_device(self, device: torch.device) -> bool:
        return self.sample_device == "train" or (self.sample_device == "auto" and device.type == "cuda")

    def _load_warm_start(self, path: str | os.PathLike) -> _NeuralInpainter:
        # Any network of the family: a U-Net's encoder may start from a saved autoencoder.
        return _NeuralInpainter.load(path)

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
        self._check_params_once()
        self._check_model_params()
        device = self._device()
        with torch_threads(self.num_threads):
            model = self.model_.to(device)
            if self.channels_last:
                model = model.to(memory_format=torch.channels_last)
            try:
                return bound_output(self._forward(self._compiled(model), X, device), X)
            finally:
                self.model_ = model.to("cpu", memory_format=torch.contiguous_format)

    # -- persistence (the hooks of PersistenceMixin) ------------------------------------------
    def _config(self) -> tuple[dict[str, Any], dict[str, torch.Tensor]]:
        """Parameters, seed, steps and history as JSON; the network's state dict as weights."""
        if not hasattr(self, "model_"):
            raise NotFittedError(f"this {type(self).__name__} is not fitted; nothing to save")
        # The config is written from the current parameters: they must still describe the weights.
        self._check_model_params()
        config = {
            "params": self._config_params(),
            "seed": getattr(self, "seed_", None),
            "fitted": {"n_steps_": getattr(self, "n_steps_", 0), "history_": getattr(self, "history_", None)},
        }
        return config, ckpt.cpu_state(self.model_)

    @classmethod
    def _from_config(cls, config: dict[str, Any], weights: dict[str, torch.Tensor], where: Any) -> Any:
        params = dict(ckpt.config_value(config, "params", dict, where))
        if params.get("crop") is not None:
            params["crop"] = tuple(ckpt.config_value(params, "crop", list, where))
        fitted = ckpt.config_value(config, "fitted", dict, where, default={})
        n_steps = ckpt.config_value(fitted, "n_steps_", int, where,
                                    default=ckpt.config_value(fitted, "step", int, where, default=0))
        history = ckpt.config_value(fitted, "history_", dict, where, default=None)
        seed = ckpt.config_value(config, "seed", int, where, default=None)
        est = ckpt.build_checked(cls, params, where)
        est.model_ = ckpt.load_weights(est._build_model(0), weights, where)
        est.history_ = history or ckpt.progress_history(fitted)
        est.n_steps_ = n_steps
        est.seed_ = seed
        est.model_params_ = est._model_params()
        return est


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

