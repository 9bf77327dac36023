"""Size limits of the learned networks, checked before anything is allocated.

A parameter (or a checkpoint's config) can ask for a network of any size: a blend width of
1e5 is 1e10 weights, ``n_members=10**7`` ten million networks, ``levels=10**6`` a million
layers; each would allocate until the process is killed, or end in ``MemoryError`` after
minutes. Every learned family checks its sizes against these limits (one ``InvalidInputError``, a ``ValueError``,
naming the parameter, the value and the limit) and, before it builds a network at ``fit`` or
``load``, the network's parameter count, counted on torch's ``meta`` device (no memory).

The limits are far above every shipped recipe (the largest, kitti-ensemble-v1's context
member, has width 64, 2 layers, 2 networks and 0.47 M parameters).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Any

import torch

from inpaintenv.exceptions import InvalidInputError

__all__ = ["MAX_LAYERS", "MAX_MEMBERS", "MAX_PARAMETERS", "MAX_THREADS", "MAX_WIDTH",
           "check_parameter_count", "usable_threads"]

#: Most hidden units of a per-pixel MLP layer (and channels of a context level, context features).
MAX_WIDTH = 4096
#: Most hidden layers of a per-pixel MLP (and levels of a context network).
MAX_LAYERS = 64
#: Most networks of a ContextBlendInpainter (``n_members``).
MAX_MEMBERS = 64
#: Most trainable parameters of one estimator's network(s): 200 M (800 MB as float32), about
#: twice the largest U-Net that ``MAX_CHANNELS`` lets through.
MAX_PARAMETERS = 200_000_000
#: Most threads a ``num_threads`` / ``predict_threads`` parameter may ask for (torch's
#: OpenMP aborts the process near 1000). Within it, a setting above this machine's cores
#: uses the cores (:func:`usable_threads`): a model trained on a large machine runs on a small one.
MAX_THREADS = 512


def usable_threads(n: int) -> int:
    """``n`` threads, at most this machine's cores (``os.cpu_count()``) and at least 1."""
    return max(1, min(int(n), os.cpu_count() or 1))


def check_parameter_count(build: Callable[[], torch.nn.Module], what: str) -> int:
    """The parameter count of the network ``build()`` makes, counted without allocating memory.

    Raises
    ------
    InvalidInputError
        (a ``ValueError``) More than :data:`MAX_PARAMETERS` parameters (``what`` names the settings that ask for them).
    """
    with torch.device("meta"):
        count = sum(p.numel() for p in build().parameters())
    if count > MAX_PARAMETERS:
        raise InvalidInputError(f"{what} gives a network of {count:,} parameters, more than the "
                                f"{MAX_PARAMETERS:,} allowed (estimators.learned._limits); lower them")
    return count
