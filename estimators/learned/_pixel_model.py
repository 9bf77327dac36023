"""What the learned models that work pixel by pixel share (BlendInpainter and its subclasses,
SparseResidualInpainter): the check that the parameters their weights depend on are unchanged,
training on pooled pixel rows, filling a batch frame by frame, and the fit record their configs keep.

Each model keeps what is its own: its features, its network, the loss of one batch, how one
frame is filled.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import torch

from inpaintenv.exceptions import InvalidInputError

from . import _checkpoint as ckpt
from ._loop import OneCycle, Optimisation, fit_loop, new_progress
from ._output import bound_output
from ._training import torch_threads

__all__ = ["check_model_params", "config_params", "fit_record", "fit_rows", "predict_frames", "read_fit_record"]


def check_model_params(est: Any) -> None:
    """Refuse to use weights whose parameters (``est._model_params()``) changed since they were made."""
    if est._model_params() != est.model_params_:
        changed = sorted(k for k, v in est._model_params().items() if est.model_params_.get(k) != v)
        raise InvalidInputError(
            f"{', '.join(changed)} changed since the weights were made ({est.model_params_}); "
            "refit, or set them back"
        )


def fit_rows(net: torch.nn.Module, n_rows: int, batch: int, est: Any, rng: np.random.Generator,
             batch_loss: Callable[[torch.Tensor], Callable[[], torch.Tensor]]) -> dict[str, list[float]]:
    """Train ``net`` on ``n_rows`` pooled pixel rows through :func:`~._loop.fit_loop`.

    Adam with a one-cycle schedule at ``est.lr`` over ``est.epochs`` epochs; each epoch a fresh
    order of the rows from ``rng``, ``batch`` rows a step, whose loss is what ``batch_loss(idx)``
    returns (called before the update, so a random draw it makes keeps its place in ``rng``).
    ``net`` is left in eval mode. Returns the history kept: ``{"epoch_loss": [...]}``.
    """
    per_epoch = max(1, n_rows // batch)
    optimisation = Optimisation(net, est.lr, schedule=OneCycle(est.lr, per_epoch * int(est.epochs)))

    def epoch_batches(epoch: int, done: int) -> Any:
        return torch.from_numpy(rng.permutation(n_rows)[: per_epoch * batch]).split(batch)

    def step(idx: torch.Tensor) -> float:
        return optimisation.update(batch_loss(idx))

    net.train()
    progress = fit_loop(new_progress(), epoch_batches, step, epochs=int(est.epochs), steps_per_epoch=per_epoch,
                        desc=type(est).__name__, verbose=bool(est.verbose))
    net.eval()
    return {"epoch_loss": progress["history"]["epoch_loss"]}


def predict_frames(est: Any, X: np.ndarray, threads: int | None) -> np.ndarray:
    """``(N, H, W)`` ``X`` filled frame by frame (``est._predict_frame``) with ``threads`` torch threads,
    after the parameter checks, bounded like every learned output."""
    est._check_params_once()
    check_model_params(est)
    out = np.empty(X.shape, np.float32)
    with torch_threads(threads), torch.inference_mode():
        for i, frame in enumerate(X):
            out[i] = est._predict_frame(frame)
    return bound_output(out, X)


def fit_record(est: Any) -> dict[str, Any]:
    """The config's ``fit`` entry: training pixels and frames, seconds, the loss per epoch."""
    return {"n_pixels": int(est.n_pixels_), "training_frames": int(est.training_frames_),
            "fit_seconds": float(est.fit_seconds_), "epoch_loss": est.history_["epoch_loss"]}


def read_fit_record(config: dict[str, Any], where: Any) -> dict[str, Any]:
    """The fit attributes a config's ``fit`` entry gives (each checked; absent: unknown), by attribute name."""
    fit = ckpt.config_value(config, "fit", dict, where, default={})
    epoch_loss = ckpt.config_value(fit, "epoch_loss", list, where, default=[])
    return {"n_pixels_": ckpt.config_value(fit, "n_pixels", int, where, default=0),
            "training_frames_": ckpt.config_value(fit, "training_frames", int, where, default=0),
            "fit_seconds_": ckpt.config_value(fit, "fit_seconds", float, where, default=float("nan")),
            "history_": {"epoch_loss": list(epoch_loss)}}


def config_params(cls: type, config: dict[str, Any], where: Any) -> tuple[dict[str, Any], dict[str, Any]]:
    """The config's ``params`` (its ``cls._TUPLE_PARAMS`` back to tuples) and ``model_params``, each checked."""
    params = dict(ckpt.config_value(config, "params", dict, where))
    for name in cls._TUPLE_PARAMS:  # type: ignore[attr-defined]
        if name in params:
            params[name] = tuple(ckpt.config_value(params, name, list, where))
    return params, dict(ckpt.config_value(config, "model_params", dict, where))
