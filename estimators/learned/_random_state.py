"""The global random streams of a training run, saved in and restored from its checkpoints."""

from __future__ import annotations

import random
from typing import Any

import numpy as np
import torch

from . import _checkpoint as ckpt

__all__ = ["global_rng_state", "set_global_rng_state"]


def global_rng_state() -> dict[str, Any]:
    """The global torch (CPU), NumPy and Python random states, as JSON.

    No training step draws from them today (weights are seeded under ``fork_rng``,
    samples by ``(seed, epoch, index)``), but user code (a custom protocol, a loss) may:
    a resumed run restores them so it continues as the uninterrupted one would have.
    """
    kind, key, pos, has_gauss, cached = np.random.get_state()
    version, internal, gauss = random.getstate()
    return {
        "torch": torch.get_rng_state().numpy().tobytes().hex(),
        "numpy": [kind, key.tolist(), int(pos), int(has_gauss), float(cached)],
        "python": [version, list(internal), gauss],
    }


def set_global_rng_state(state: dict[str, Any] | None) -> None:
    """Restore what :func:`global_rng_state` returned (None: a checkpoint that recorded none).

    Raises
    ------
    CheckpointError
        If ``state`` is not such a record.
    """
    if state is None:
        return
    try:
        torch_state = torch.frombuffer(bytearray.fromhex(state["torch"]), dtype=torch.uint8)
        kind, key, pos, has_gauss, cached = state["numpy"]
        version, internal, gauss = state["python"]
        numpy_state = (kind, np.asarray(key, dtype=np.uint32), int(pos), int(has_gauss), float(cached))
        python_state = (int(version), tuple(int(v) for v in internal), gauss)
        torch.set_rng_state(torch_state.clone())
        np.random.set_state(numpy_state)
        random.setstate(python_state)
    except (KeyError, TypeError, ValueError, RuntimeError) as e:
        raise ckpt.CheckpointError(f"the training checkpoint's global random state is not readable: {e}") from None
