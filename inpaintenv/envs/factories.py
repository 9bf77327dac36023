"""Entry points of the registered env ids: build the data source, then the env.

The data modules are imported lazily, so registering the ids on ``import inpaintenv``
stays cheap and works before a data source is used.
"""

from __future__ import annotations

from typing import Any

from ..conventions import DEFAULT_MAX_DEPTH
from .inpaint import DepthInpaintEnv

__all__ = ["make_kitti_env", "make_synthetic_env"]

#: Marks a keyword the caller did not pass, so the data source's own default applies.
_UNSET: Any = object()


def _given(**kwargs: Any) -> dict[str, Any]:
    return {k: v for k, v in kwargs.items() if v is not _UNSET}


def make_kitti_env(
    root: Any = None,
    split: Any = _UNSET,
    camera: Any = _UNSET,
    kind: Any = _UNSET,
    crop: Any = _UNSET,
    protocol: str = "rect-v1",
    max_depth: float = DEFAULT_MAX_DEPTH,
    render_mode: str | None = None,
    unfilled: str = "error",
    input: Any = _UNSET,
) -> DepthInpaintEnv:
    """``inpaintenv/KittiInpaint-v0``: the env on real KITTI depth (:class:`KittiDepth`).

    ``root``, ``split``, ``camera``, ``kind``, ``crop`` and ``input`` (``"scan"``: each
    frame's single scan is the input) go to ``KittiDepth``; keywords not given keep
    ``KittiDepth``'s defaults.
    """
    from ..data.kitti import KittiDepth

    dataset = KittiDepth(root, **_given(split=split, camera=camera, kind=kind, crop=crop, input=input))
    return DepthInpaintEnv(dataset, protocol=protocol, max_depth=max_depth, render_mode=render_mode, unfilled=unfilled)


def make_synthetic_env(
    n: Any = _UNSET,
    seed: Any = _UNSET,
    frame_shape: Any = _UNSET,
    protocol: str = "rect-v1",
    max_depth: float = DEFAULT_MAX_DEPTH,
    render_mode: str | None = None,
    unfilled: str = "error",
    input: Any = _UNSET,
) -> DepthInpaintEnv:
    """``inpaintenv/SyntheticInpaint-v0``: the env on the built-in :class:`SyntheticStreets`.

    ``n``, ``seed``, ``frame_shape`` and ``input`` (``"scan"``: each frame's simulated
    scan is the input) go to ``SyntheticStreets``; keywords not given keep its defaults.
    """
    from ..data.synthetic import SyntheticStreets

    dataset = SyntheticStreets(**_given(n=n, seed=seed, frame_shape=frame_shape, input=input))
    return DepthInpaintEnv(dataset, protocol=protocol, max_depth=max_depth, render_mode=render_mode, unfilled=unfilled)
