"""One entry point for "a data source": real KITTI when a root is given, else synthetic."""

from __future__ import annotations

import os
from collections.abc import Sequence

from ..conventions import check_int
from .base import ConcatDataset, DepthDataset, Subset, select_drives
from .inputs import check_input_kind
from .kitti import KittiDepth
from .synthetic import SyntheticStreets
from ..exceptions import InvalidInputError, InvalidTypeError

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
    drives: Sequence[str] | None = None,
    exclude_drives: Sequence[str] | None = None,
    input: str = "map",
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
        KITTI split (``"train"``, ``"val"``, ``"val_selection"``), or several joined by
        commas (``"train,val"``: one dataset, train frames first); ignored for synthetic data.
    kind : {"groundtruth", "velodyne_raw"} or "dense"
        ``"dense"`` exists only for synthetic data.
    n_frames : int, optional
        Keep only the first ``n_frames`` frames (deterministic). For synthetic data this
        is the number of frames generated (default 64).
    seed : int
        Seed of the synthetic streets; ignored for KITTI.
    camera : str
        KITTI camera (``"image_02"``, ``"image_03"`` or ``"both"``); ignored for synthetic.
    drives, exclude_drives : sequence of str, optional
        Keep only / drop these drives (applied before ``n_frames``), e.g. to score on
        drives a model never saw.
    input : {"map", "scan"}
        What a method is given (:mod:`inpaintenv.data.inputs`): the ground-truth map, or
        each frame's single scan paired with its ground truth (needs ``kind="groundtruth"``).

    Returns
    -------
    DepthDataset
    """
    if n_frames is not None:
        n_frames = check_int(n_frames, "n_frames", minimum=1)  # int("abc") failed obscurely
    if not isinstance(split, str):
        raise InvalidTypeError(f"split must be a string such as 'train' or 'train,val', got {split!r}")
    input = check_input_kind(input)
    if kitti_root is None:
        n = DEFAULT_SYNTHETIC_FRAMES if n_frames is None else int(n_frames)
        return select_drives(SyntheticStreets(n=n, seed=seed, kind=kind, input=input), drives, exclude_drives)
    if kind == "dense":
        raise InvalidInputError("kind='dense' exists only for the synthetic source (KITTI has no dense truth)")
    splits = [s.strip() for s in split.split(",") if s.strip()]
    if not splits:
        raise InvalidInputError(f"no KITTI split named in {split!r}")
    parts = [KittiDepth(kitti_root, split=s, camera=camera, kind=kind, input=input) for s in splits]
    ds = select_drives(parts[0] if len(parts) == 1 else ConcatDataset(parts), drives, exclude_drives)
    if n_frames is not None and n_frames < len(ds):
        return Subset(ds, range(int(n_frames)))
    return ds
