"""Export the occluded inputs of a benchmark as files any program can read.

For every frame and seed: the input a method gets in :func:`inpaintenv.evaluate.evaluate`
(the ground truth with the protocol's hole) as a KITTI 16-bit depth PNG, with 0 = hole or
no measurement, and the hole mask as an 8-bit PNG; then ``manifest.json``
(:mod:`.manifest`). Ground truth is never exported. The export is built in a temporary
folder beside ``out`` and moved into place only when complete, so an error or Ctrl-C
leaves nothing half-written.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from .._version import __version__
from ..conventions import check_int, check_seeds
from ..data.base import Subset
from ..data.io import KITTI_DEPTH_SCALE, write_depth_png
from ..evaluate import resolve_source
from ..masks import OcclusionProtocol, get_protocol
from .layout import (
    DEPTH_ENCODING,
    HOLE_ENCODING,
    HOLE_VALUE,
    array_sha256,
    file_sha256,
    frame_parts,
    hole_bits_sha256,
    relative_paths,
)
from .manifest import MANIFEST_NAME, Frame, Item, Manifest, read_manifest
from .truth import describe_truth

__all__ = ["export", "protocol_record"]


def protocol_record(protocol: OcclusionProtocol) -> dict[str, Any]:
    """The manifest's ``protocol``: name, version (the name's ``-vN`` suffix) and full description."""
    name = protocol.name
    version = name.rsplit("-", 1)[-1] if "-v" in name else None
    return {"name": name, "version": version, "description": protocol.describe()}


def _prepare_out(out: Path, overwrite: bool) -> bool:
    """Check that ``out`` may receive an export; True if an earlier export is to be replaced."""
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out} is a file; give a folder for the export")
    if not out.exists() or not any(out.iterdir()):
        return False
    if not (out / MANIFEST_NAME).is_file():
        raise ValueError(f"--out {out} is not empty and holds no export; give a new or empty folder")
    if not overwrite:
        raise ValueError(f"--out {out} holds an earlier export; pass --overwrite (overwrite=True) to replace it")
    # Replace only what an export wrote: a file of the user's in there is never deleted.
    old = read_manifest(out)
    listed = {MANIFEST_NAME} | {i.input for i in old.items} | {i.hole for i in old.items}
    foreign = sorted(p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()
                     and p.relative_to(out).as_posix() not in listed)
    if foreign:
        raise ValueError(f"--out {out} holds files its manifest does not list ({', '.join(foreign[:3])}"
                         f"{', …' if len(foreign) > 3 else ''}); move them or give another folder")
    return True


def export(
    out: str | os.PathLike,
    source: Any = None,
    protocol: str | OcclusionProtocol = "rect-v1",
    seeds: int | Sequence[int] = (0,),
    *,
    n_frames: int | None = None,
    overwrite: bool = False,
    progress: bool = True,
) -> Manifest:
    """Write the occluded inputs, hole masks and ``manifest.json`` of every (frame, seed).

    Parameters
    ----------
    out : path-like
        Folder of the export: new, empty, or (with ``overwrite``) an earlier export.
    source : DepthDataset, array-like or None
        Ground truth, as for :func:`~inpaintenv.evaluate.evaluate` (None: the built-in
        SyntheticStreets default). KITTI frames are recorded by file, SyntheticStreets
        by its parameters; any other dataset by the sha256 of each frame (``score`` then
        needs it passed in).
    protocol : str or OcclusionProtocol
    seeds : int or sequence of int
        Evaluation seeds, distinct non-negative integers.
    n_frames : int, optional
        Export only the first ``n_frames`` frames.
    overwrite : bool
        Replace an earlier export in ``out`` (only files its manifest lists are removed).
    progress : bool
        A tqdm bar on stderr when it is a terminal.

    Returns
    -------
    Manifest

    Raises
    ------
    ValueError
        On a bad ``out``, seeds, protocol or source; ground truth below 1/512 m (it would
        read as 0 = no measurement in KITTI's encoding).
    """
    dataset = resolve_source(source)
    proto = get_protocol(protocol)
    seed_list = check_seeds(seeds, "seeds")
    total = len(dataset)
    if total == 0:
        raise ValueError("the data source has no frames")
    if n_frames is not None:
        total = min(total, check_int(n_frames, "n_frames", minimum=1))
    if total < len(dataset):
        dataset = Subset(dataset, range(total))
    out = Path(out)
    replace = _prepare_out(out, overwrite)
    shape = tuple(int(s) for s in dataset.frame_shape)
    truth, per_frame = describe_truth(dataset)
    parts = frame_parts(dataset.frame_ids, [str(g) for g in dataset.groups])

    tmp = out.parent / f".{out.name}.partial-{os.getpid()}"
    shutil.rmtree(tmp, ignore_errors=True)
    from tqdm.auto import tqdm  # lazy: only needed when looping

    bar = tqdm(total=total * len(seed_list), desc="export", unit="frame", disable=None if progress else True, leave=False)
    try:
        frames: list[Frame] = []
        by_seed: dict[int, list[Item]] = {s: [] for s in seed_list}
        for i in range(total):
            gt = dataset.load_batch([i])[0]
            tiny = (gt > 0) & (gt < 0.5 / KITTI_DEPTH_SCALE)
            if tiny.any():
                raise ValueError(f"frame {i} ({dataset.frame_ids[i]}) has depth below 1/512 m, which KITTI's "
                                 "16-bit encoding stores as 0 (no measurement)")
            split, fields = per_frame[i]
            if "ground_truth_sha256" not in fields:
                fields = {**fields, "ground_truth_sha256": array_sha256(gt)}
            frames.append(Frame(index=i, frame_id=str(dataset.frame_ids[i]), drive=str(dataset.groups[i]), **fields))
            for seed in seed_list:
                hole = proto.mask(shape, seed, i)
                input_rel, hole_rel = relative_paths(proto.name, seed, split, parts[i])
                write_depth_png(tmp / input_rel, np.where(hole, np.float32(0), gt))
                (tmp / hole_rel).parent.mkdir(parents=True, exist_ok=True)
                if not cv2.imwrite(str(tmp / hole_rel), hole.astype(np.uint8) * np.uint8(HOLE_VALUE)):
                    raise OSError(f"could not write {tmp / hole_rel}")
                by_seed[seed].append(Item(
                    seed=seed, index=i, input=input_rel, hole=hole_rel, input_sha256=file_sha256(tmp / input_rel),
                    hole_sha256=file_sha256(tmp / hole_rel), hole_bits_sha256=hole_bits_sha256(hole),
                ))
                bar.update(1)
        manifest = Manifest(
            path=out / MANIFEST_NAME, protocol=protocol_record(proto), seeds=seed_list, frame_shape=shape,  # type: ignore[arg-type]
            ground_truth=truth, frames=frames, items=[it for s in seed_list for it in by_seed[s]],
            inpaintenv_version=__version__,
            extra={"encoding": {"input": DEPTH_ENCODING, "hole": HOLE_ENCODING}},
        )
        manifest.write(tmp / MANIFEST_NAME)
        if replace:
            trash = out.parent / f".{out.name}.replaced-{os.getpid()}"
            os.replace(out, trash)
            os.replace(tmp, out)
            shutil.rmtree(trash)
        else:
            if out.exists():
                out.rmdir()  # empty, checked above
            os.replace(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    finally:
        bar.close()
    return manifest
