"""What the parameters of the neural inpainters may be and mean, as a table and plain functions.

:class:`estimators.learned._neural._NeuralInpainter` stores its ``__init__`` arguments as
given and checks them against :data:`NEURAL_CONSTRAINTS` (:data:`STUDY_CONSTRAINTS` for the
study's two networks) at ``fit`` / ``predict`` time; the functions here turn checked values
into what torch is given: the device, the autocast context, the compiled module, the depth
scale, and the JSON form of the parameters.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
from typing import Any

import numpy as np
import torch

from inpaintenv.exceptions import InvalidInputError, InvalidTypeError
from inpaintenv.masks import get_protocol

from ..base import check_random_state
from ._checkpoint import cpu_state
from .._constraints import Bool, Check, InstanceOf, Integer, Options, Pair, Real
from ._limits import MAX_THREADS
from ._training import TrainingMixin

__all__ = ["MAX_CHANNELS", "NEURAL_CONSTRAINTS", "STUDY_CONSTRAINTS", "autocast", "compiled", "config_params",
           "input_scale", "plain", "resolve_device"]

_AMP_CHOICES = (True, False, "cpu-bf16")
_DEPTH_SCALES = ("fixed", "frame")
_COMPILE_MODES = ("default", "reduce-overhead", "max-autotune", "max-autotune-no-cudagraphs")
_SAMPLE_DEVICES = ("auto", "cpu", "train")
#: Largest ``depth_jitter``: a sample at most twice as near or as far as recorded.
_MAX_DEPTH_JITTER = 2.0
#: Accepted ``max_depth`` range (metres).
_MAX_DEPTH_RANGE = (0.1, 1e5)
#: Most channels allowed at the deepest U-Net level (``width * 2**depth``). The U-Net
#: doubles its channels per level, so each extra level about quadruples the parameters:
#: 2048 (e.g. width=128, depth=4) is already ~100 M parameters, while width=4, depth=12
#: (16,384 channels) needs tens of GB and gets the process killed.
MAX_CHANNELS = 2048


_DEVICES = "'auto', 'cpu', 'cuda', 'cuda:N' or 'mps'"


def _check_device_type(value: Any) -> None:
    """Accept a device name or ``torch.device``; anything else is one ``TypeError``."""
    if not isinstance(value, (str, torch.device)):
        raise InvalidTypeError(f"device must be one of {_DEVICES}, got {value!r}")


def _check_warm_start(value: Any) -> None:
    """Accept a neural inpainter (its encoder warm-starts the fit); anything else is one error."""
    if not isinstance(value, TrainingMixin):
        raise InvalidTypeError("warm_start must be None, a bool, a path to a saved model or a neural inpainter, "
                               f"got {type(value).__name__}")


#: What each parameter of a neural inpainter may be (scikit-learn's ``_parameter_constraints``).
NEURAL_CONSTRAINTS: dict[str, list[Any]] = {
    "width": [Integer(1)],
    "depth": [Integer(1)],
    "input_mask": [Bool()],
    "depth_scale": [Options(*_DEPTH_SCALES)],
    "hole_weight": [Real(0)],
    "tv_weight": [Real(0)],
    # Depths are divided by it: far outside this range (metres) inputs and targets
    # overflow or vanish in float32 and training fails with an unexplained NaN loss.
    "max_depth": [Real(*_MAX_DEPTH_RANGE)],
    "lr": [Real(0, closed="neither")],
    "weight_decay": [Real(0)],
    "batch_size": [Integer(1)],
    "epochs": [Integer(1)],
    "max_steps": [Integer(1), None],
    "max_minutes": [Real(0, closed="neither"), None],
    "crop": [Pair(Integer(1), "a pair of integers >= 1 (h, w)"), None],
    "protocol": [Check(get_protocol)],  # an unknown name lists the known protocols
    "validation_fraction": [Real(0, 1, closed="neither"), None],
    "amp": [Options(*_AMP_CHOICES)],
    "channels_last": [Bool()],
    "compile": [Bool(), InstanceOf(dict, "a dict of torch.compile arguments"), Options(*_COMPILE_MODES)],
    "num_threads": [Integer(1, limit=MAX_THREADS), None],
    "num_workers": [Integer(0)],
    "random_state": [Check(check_random_state)],
    "checkpoint_every": [Integer(1), None],
    "checkpoint_dir": [InstanceOf((str, os.PathLike), "a folder path"), None],
    # Whether the device exists is checked where it is used (_device).
    "device": [Check(_check_device_type)],
    "warm_start": [Bool(), InstanceOf((str, os.PathLike), "a path to a saved model"), Check(_check_warm_start),
                   None],
    "keep_observed": [Bool()],
    "verbose": [Bool(), Integer(0)],
}


#: The table of the study's two networks (U-Net, autoencoder): the shared one plus their
#: augmentation and sampling parameters. Kept apart because PriorUNetInpainter builds its
#: table from the shared one and has neither (it flips its own features, on the CPU).
STUDY_CONSTRAINTS: dict[str, list[Any]] = {
    **NEURAL_CONSTRAINTS,
    "flip": [Bool()],
    "depth_jitter": [Real(1, _MAX_DEPTH_JITTER, closed="right"), None],
    "sample_device": [Options(*_SAMPLE_DEVICES)],
}


def plain(value: Any) -> Any:
    """``value`` with NumPy scalars as Python ones and lists as tuples, for comparison."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, (list, tuple)):
        return tuple(plain(v) for v in value)
    return value


def _weights_hash(est: Any) -> str:
    h = hashlib.sha256()
    for k, v in sorted(cpu_state(est.model_).items()):
        h.update(k.encode())
        h.update(v.float().numpy().tobytes())
    return h.hexdigest()[:16]

def resolve_device(device: Any) -> torch.device:
    """The torch device ``device`` names; a clear ValueError for anything unusable.

    Accepted: "auto", "cpu", "cuda", "cuda:N" (N < the number of GPUs) and "mps"
    where available. Other torch device types ("meta", "xla", ...) would only fail
    later, deep inside autocast or a kernel.
    """
    choices = _DEVICES
    if device == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    _check_device_type(device)
    try:
        dev = torch.device(device)
    except (RuntimeError, TypeError, ValueError):
        raise InvalidInputError(f"device must be one of {choices}, got {device!r}") from None
    if dev.type == "cpu":
        return dev
    if dev.type == "cuda":
        if not torch.cuda.is_available():
            raise InvalidInputError(f"device={device!r} but no CUDA device is available; use device='auto' or 'cpu'")
        if dev.index is not None and dev.index >= torch.cuda.device_count():
            raise InvalidInputError(
                f"device={device!r} but only {torch.cuda.device_count()} CUDA device(s) are visible"
            )
        return dev
    if dev.type == "mps":
        if not torch.backends.mps.is_available():
            raise InvalidInputError(f"device={device!r} but MPS is not available here; use device='auto' or 'cpu'")
        return dev
    raise InvalidInputError(f"device must be one of {choices}, got {device!r} (device type {dev.type!r} is not supported)")


def autocast(amp: Any, device: torch.device) -> tuple[Any, bool]:
    """Autocast context of ``amp`` for ``device`` and whether fp16 gradient scaling is needed."""
    # As documented: autocast on CUDA, and on CPU only with "cpu-bf16"; never on
    # other devices (MPS), whose autocast support varies across torch versions.
    if amp is False or device.type not in ("cpu", "cuda") or (device.type == "cpu" and amp != "cpu-bf16"):
        return contextlib.nullcontext(), False
    if device.type == "cuda" and amp is True and not torch.cuda.is_bf16_supported():
        return torch.autocast("cuda", dtype=torch.float16), True
    return torch.autocast(device.type, dtype=torch.bfloat16), False


def input_scale(observed: torch.Tensor, depth_scale: str, max_depth: float) -> torch.Tensor | float:
    """Metres per network unit: ``max_depth``, or each frame's mean observed depth.

    ``observed`` is ``(N, H, W)`` metres with 0 in holes and where unmeasured; the
    frame scale is returned as ``(N, 1, 1)`` so it broadcasts over pixels. A frame
    with nothing observed falls back to ``max_depth``; the floor of 1 m keeps a
    frame of a few very near points from blowing up the input.
    """
    if depth_scale == "fixed":
        return max_depth
    valid = observed > 0
    count = valid.sum(dim=(1, 2), keepdim=True)
    mean = observed.sum(dim=(1, 2), keepdim=True) / count.clamp(min=1)
    return torch.where(count > 0, mean.clamp(min=1.0), torch.full_like(mean, max_depth))


def compiled(model: torch.nn.Module, compile: Any) -> torch.nn.Module:
    """``model`` through ``torch.compile`` as the ``compile`` parameter asks, else itself.

    The compiled wrapper shares the module's parameters, so optimiser, checkpoints
    and ``train()``/``eval()`` keep working on the plain module.
    """
    if isinstance(compile, dict):
        kwargs = dict(compile)
    elif isinstance(compile, str):
        kwargs = {"mode": compile}
    elif compile:  # True or numpy.True_ (the parameter check accepts both)
        kwargs = {}
    else:
        return model
    return torch.compile(model, **kwargs)


def config_params(est: Any) -> dict[str, Any]:
    """``est``'s parameters as JSON-able values (run-folder key, checkpoint config; a warm-start
    estimator becomes a weight hash)."""
    params = est.get_params(deep=False)
    ws = params["warm_start"]
    if isinstance(ws, bool):
        params["warm_start"] = ws
        if ws and hasattr(est, "model_"):
            params["warm_start"] = f"<previous fit sha256:{_weights_hash(est)}>"
    elif isinstance(ws, TrainingMixin):
        params["warm_start"] = f"<{type(ws).__name__} weights sha256:{_weights_hash(ws)}>" if hasattr(ws, "model_") else f"<unfitted {type(ws).__name__}>"
    elif ws is not None:
        params["warm_start"] = str(ws)
    if params["crop"] is not None:
        params["crop"] = [int(v) for v in params["crop"]]
    if params["checkpoint_dir"] is not None:
        params["checkpoint_dir"] = str(params["checkpoint_dir"])
    if isinstance(params["random_state"], (np.random.RandomState, np.random.Generator)):
        # A generator is not JSON: record the seed the fit drew from it (None before a fit).
        params["random_state"] = getattr(est, "seed_", None)
    return {k: (v.item() if isinstance(v, np.generic) else v) for k, v in params.items()}
