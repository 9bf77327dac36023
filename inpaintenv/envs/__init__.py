"""Gymnasium environment: serves one occluded frame per episode and scores the reconstruction.

Registered on ``import inpaintenv``:

* ``inpaintenv/KittiInpaint-v0`` -- real KITTI depth (kwargs ``root``, ``split``,
  ``camera``, ``kind``, ``crop``, ``input``, ``protocol``);
* ``inpaintenv/SyntheticInpaint-v0`` -- the built-in synthetic streets (kwargs ``n``,
  ``seed``, ``frame_shape``, ``input``, ``protocol``);
* ``inpaintenv/DepthInpaint-v0`` -- any dataset or array (kwarg ``dataset``).
"""

from __future__ import annotations

from .inpaint import DEPTH_LIMIT, DepthInpaintEnv, draw_scored_hole
from .render import render_panel

__all__ = ["DEPTH_LIMIT", "ENV_IDS", "DepthInpaintEnv", "draw_scored_hole", "register_envs", "render_panel"]

#: Env ids and their entry points.
ENV_IDS: dict[str, str] = {
    "inpaintenv/KittiInpaint-v0": "inpaintenv.envs.factories:make_kitti_env",
    "inpaintenv/SyntheticInpaint-v0": "inpaintenv.envs.factories:make_synthetic_env",
    "inpaintenv/DepthInpaint-v0": "inpaintenv.envs.inpaint:DepthInpaintEnv",
}


def register_envs() -> None:
    """Register :data:`ENV_IDS` with Gymnasium (idempotent)."""
    import gymnasium as gym

    for env_id, entry_point in ENV_IDS.items():
        if env_id not in gym.registry:
            gym.register(id=env_id, entry_point=entry_point)
