"""inpaintenv: a benchmark for depth-only inpainting of large occlusions in outdoor depth.

The benchmark knows nothing about any particular method: it serves frames with
occlusions and scores any reconstruction.
"""

from __future__ import annotations

from ._version import __version__
from .conventions import DEFAULT_MAX_DEPTH, corrupt
from .envs import DepthInpaintEnv
from .envs import register_envs as _register_envs
from .evaluate import evaluate

__all__ = ["DEFAULT_MAX_DEPTH", "DepthInpaintEnv", "corrupt", "evaluate", "__version__"]

_register_envs()
