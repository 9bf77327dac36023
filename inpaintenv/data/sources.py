"""One entry point for "a data source": real KITTI when a root is given, else synthetic."""

from __future__ import annotations

import os

from .base import DepthDataset, Subset
from .kitti import KittiDepth
from .synthetic import SyntheticStreets

__all__ = ["open_source", "DEFAULT_SYNTHETIC_FRAMES"]

#: Frames of the built-in synthetic source when ``n_frames`` is not given.
DEFAULT_SYNTHETIC_FRAMES = 64


def open_source(
    kitti_root: str | os.PathLike | None = None,
    split: str = "train",
    kind: str = "groundtruth",
    n_frames: int | None = None,
    seed: int = 0,
    camera: str = "image_02",
) -> DepthDataset:
    """Open the data source used by the CLI, the environments and the benchmarks.

    ``KittiDepth`` when ``kitti_root`` is given, otherwise the built-in
    ``SyntheticStreets``. ``$INPAINTENV_KITTI_ROOT`` is deliberately *not* consulted
    here, so that the default source is the same on every machine; callers that want
    it (e.g. a ``--kitti-root`` option defaulting to the variable) pass it explicitly.

    Parameters
    ----------
    kitti_root : path-like, optional
        Root of the KITTI depth-completion data (see :class:`KittiDepth`).
    split : str
        KITTI split (``"train"``, ``"val"``, ``"val_selection"``); ignored for synthetic data.
    kind : {"groundtruth", "velodyne_raw"} or "dense"
        ``"dense"`` exists only for synthetic data.
    n_frames : int, optional
        Keep only the first ``n_frames`` frames (deterministic). For synthetic data this
        is the number of frames generated (default 64).
    seed : int
        Seed of the synthetic streets; ignored for KITTI.
    camera : str
        KITTI camera (``"image_02"``, ``"image_03"`` or ``"both"``); ignored for synthetic.

    Returns
    -------
    DepthDataset
    """
    if n_frames is not None and (int(n_frames) != n_frames or n_frames < 1):
        raise ValueError(f"n_frames must be a positive integer or None, got {n_frames!r}")
    if kitti_root is None:
        n = DEFAULT_SYNTHETIC_FRAMES if n_frames is None else int(n_frames)
        return SyntheticStreets(n=n, seed=seed, kind=kind)
    if kind == "dense":
        raise ValueError("kind='dense' exists only for the synthetic source (KITTI has no dense truth)")
    ds = KittiDepth(kitti_root, split=split, camera=camera, kind=kind)
    if n_frames is not None and n_frames < len(ds):
        return Subset(ds, range(int(n_frames)))
    return ds
