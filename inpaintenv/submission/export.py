"""Export the occluded inputs of a benchmark as files any program can read.

For every frame: the input a method gets in :func:`inpaintenv.evaluate.evaluate` (the
ground truth with the protocol's hole, or for a source of scans the frame's single LiDAR
scan with the hole cut out: ``where(hole, 0, scan)``) as a KITTI 16-bit depth PNG, with
0 = hole or no measurement, and the hole mask as an 8-bit PNG; the kit's
``manifest.json``; and, outside the export folder, the score key (:mod:`.manifest`).
Ground truth is never exported.

A submission export draws **one mask per frame** (one seed): with several seeds, each
input would show the other seeds' holes as measured depth, so the maximum over a frame's
inputs would be its ground truth. Several seeds need ``trusted=True``, for an export
that only one's own method sees.

The export is built in a temporary folder beside ``out``, created exclusively under an
unpredictable name (a link planted at a guessed name cannot redirect it), and moved into
place only when complete; the score key is written through :func:`inpaintenv.files.write_atomic`.
So an error or Ctrl-C leaves nothing half-written; a later export removes the temporary
folders that killed exports of the same user left behind.
"""

from __future__ import annotations

import os
import re
import secrets
import shutil
import stat
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .._version import __version__
from ..conventions import check_int, check_seeds
from ..data.base import Subset
from ..data.inputs import INPUTS
from ..data.io import KITTI_DEPTH_SCALE, write_depth_png, write_png
from ..evaluate import resolve_source
from ..files import describe_kind, remove_stale_temporaries, write_atomic
from ..files.processes import writer_gone
from ..masks import OcclusionProtocol, get_protocol
from .layout import (
    DEPTH_ENCODING,
    HOLE_ENCODING,
    HOLE_VALUE,
    array_sha256,
    file_sha256,
    frame_parts,
    hole_bits_sha256,
    is_inside,
    relative_paths,
)
from .manifest import KEY, KIT, MANIFEST_NAME, Frame, Item, Manifest, ManifestError, default_key_path, read_manifest
from .truth import describe_truth
from ..exceptions import InvalidInputError, InvalidTypeError, UnsafeFileError

__all__ = ["check_one_mask_per_frame", "clean_stale", "export", "protocol_record"]


def protocol_record(protocol: OcclusionProtocol) -> dict[str, Any]:
    """The manifest's ``protocol``: name, version (the name's ``-vN`` suffix) and full description."""
    name = protocol.name
    version = name.rsplit("-", 1)[-1] if "-v" in name else None
    return {"name": name, "version": version, "description": protocol.describe()}


def check_one_mask_per_frame(seeds: list[int], trusted: bool, option: str = "trusted=True") -> None:
    """Refuse several seeds in an export for a submitter: each input would show the others' holes.

    Raises
    ------
    ValueError
        If ``seeds`` has more than one seed and ``trusted`` is False.
    """
    if len(seeds) > 1 and not trusted:
        raise InvalidInputError(
            f"a submission export draws one mask per frame: with seeds {', '.join(map(str, seeds))} each input would "
            "show the other seeds' holes as measured depth (the hidden ground truth); export one seed, or pass "
            f"{option} for an export that only your own method sees"
        )


def _our_files(out: Path) -> dict[str, str]:
    """Relative path -> recorded sha256 of every file an earlier export in ``out`` wrote (its kit manifest)."""
    try:
        old = read_manifest(out)
    except ManifestError as exc:
        raise InvalidInputError(f"--out {out} holds a manifest.json that cannot tell which files are the export's ({exc}); "
                         "move it or give another folder") from None
    if old.role != KIT:
        raise InvalidInputError(f"--out {out}/manifest.json is not an export's kit manifest; give another folder")
    recorded = {i.input: i.input_sha256 for i in old.items}
    recorded.update({i.hole: i.hole_sha256 for i in old.items})
    return recorded


def _prepare_out(out: Path, overwrite: bool) -> bool:
    """Check that ``out`` may receive an export; True if an earlier export is to be replaced.

    An earlier export is replaced only if every file in it is one the export wrote: listed
    in its manifest, below the folder (no links) and unchanged since (its recorded sha256),
    so a file of the user's, even one an edited manifest lists, is never deleted.
    """
    if out.exists() and not out.is_dir():
        raise InvalidInputError(f"--out {out} is a file; give a folder for the export")
    if not out.exists() or not any(out.iterdir()):
        return False
    manifest = out / MANIFEST_NAME
    if os.path.lexists(manifest) and not stat.S_ISREG(os.lstat(manifest).st_mode):
        kind = describe_kind(os.lstat(manifest).st_mode)
        raise UnsafeFileError(f"--out {out}: its {MANIFEST_NAME} is {kind}, not an export's manifest; give a new or "
                              "empty folder")
    if not manifest.is_file():
        raise InvalidInputError(f"--out {out} is not empty and holds no export; give a new or empty folder")
    if not overwrite:
        raise InvalidInputError(f"--out {out} holds an earlier export; pass --overwrite (overwrite=True) to replace it")
    recorded = _our_files(out)
    foreign = []
    for folder, dirs, files in os.walk(out):
        for name in [*dirs, *files]:
            path = Path(folder) / name
            rel = path.relative_to(out).as_posix()
            mode = os.lstat(path).st_mode
            if stat.S_ISDIR(mode) or rel == MANIFEST_NAME:
                continue
            if not stat.S_ISREG(mode) or rel not in recorded or \
                    file_sha256(path, "exported file", follow_links=False) != recorded[rel]:
                foreign.append(rel)
    if foreign:
        raise InvalidInputError(f"--out {out} holds files the earlier export did not write, or changed since "
                         f"({', '.join(sorted(foreign)[:3])}{', …' if len(foreign) > 3 else ''}); move them or give "
                         "another folder")
    return True


def clean_stale(out: Path) -> list[Path]:
    """Remove the temporary folders and files that killed exports into ``out`` left beside it.

    Only ``.<out>.partial-<pid>-<random>`` (and ``.<out>.replaced-<pid>-<random>`` when
    ``out`` itself is in place, and the key's ``.<key>.partial-<pid>`` of earlier versions)
    whose process is gone and which belong to this user are removed; a name whose pid does not
    parse (:func:`inpaintenv.files.processes.parse_pid`) is left alone. Returns what was removed.
    """
    removed = []
    pattern = re.compile(rf"^\.{re.escape(out.name)}(?:\.key\.json)?\.(partial|replaced)-([0-9]+)(?:-[0-9a-f]+)?$",
                         re.ASCII)
    if not out.parent.is_dir():
        return removed
    for entry in out.parent.iterdir():
        match = pattern.match(entry.name)
        if match is None:
            continue
        info = os.lstat(entry)
        if not writer_gone(match.group(2)) or info.st_uid != os.getuid() or stat.S_ISLNK(info.st_mode):
            continue
        if match.group(1) == "replaced" and not out.is_dir():
            continue  # killed between the two renames: the only copy of the earlier export
        if stat.S_ISDIR(info.st_mode):
            shutil.rmtree(entry)
        else:
            entry.unlink()
        removed.append(entry)
    return removed


def _new_folder(out: Path, kind: str) -> Path:
    """A new empty folder beside ``out``, created exclusively under an unpredictable name.

    ``mkdir`` fails on anything already there, a planted link included, so nothing of the
    export is ever written through a name someone else chose.
    """
    out.parent.mkdir(parents=True, exist_ok=True)
    folder = out.parent / f".{out.name}.{kind}-{os.getpid()}-{secrets.token_hex(8)}"
    folder.mkdir()
    return folder


def _install(tmp: Path, out: Path, replace: bool) -> None:
    """Move the complete export ``tmp`` to ``out`` (an earlier export there is moved aside, then removed).

    Whole folders are renamed, which never writes through a link; a file is never replaced here.
    """
    if replace:
        trash = out.parent / f".{out.name}.replaced-{os.getpid()}-{secrets.token_hex(8)}"
        out.rename(trash)
        tmp.rename(out)
        shutil.rmtree(trash)
    else:
        if out.exists():
            out.rmdir()  # empty, checked before
        tmp.rename(out)


def _check_task(proto: OcclusionProtocol, input_kind: str) -> None:
    """Refuse a protocol that poses no task on this input (``densify-v1`` on maps: nothing is unmeasured)."""
    if INPUTS[input_kind].is_map and proto.task == "unmeasured":
        raise InvalidInputError(f"{proto.name} fills what a single scan did not measure: a map input has nothing to "
                                "fill; export a source of scans (--input scan, input='scan')")


def _load_frame(dataset: Any, i: int) -> tuple[np.ndarray, np.ndarray]:
    """``(input, ground truth)`` of frame ``i``; the input, which is written, must survive KITTI's encoding."""
    inputs, gt = dataset.load_pairs([i])
    scan = dataset.input.separate
    tiny = (inputs[0] > 0) & (inputs[0] < 0.5 / KITTI_DEPTH_SCALE)
    if tiny.any():
        raise InvalidInputError(f"{'the scan of ' if scan else ''}frame {i} ({dataset.frame_ids[i]}) has depth below "
                                "1/512 m, which KITTI's 16-bit encoding stores as 0 (no measurement)")
    return inputs[0], gt[0]


def _frame_record(dataset: Any, i: int, fields: dict[str, Any], inputs: np.ndarray, gt: np.ndarray) -> Frame:
    """The score key's :class:`Frame` of frame ``i``: ``fields`` of :func:`describe_truth`, and the sha256 of
    generated frames (and scans), which only loading them gives."""
    if "ground_truth_sha256" not in fields:
        fields = {**fields, "ground_truth_sha256": array_sha256(gt)}
    if dataset.input.separate and "scan_sha256" not in fields:
        fields = {**fields, "scan_sha256": array_sha256(inputs)}
    return Frame(index=i, frame_id=str(dataset.frame_ids[i]), drive=str(dataset.groups[i]), **fields)


def _prepare_key(key: Path, out: Path, overwrite: bool) -> None:
    """Check that the score key may be written at ``key``: outside the export, and replacing only a key."""
    if is_inside(key, out):
        raise InvalidInputError(f"the score key {key} would lie in the export {out}, which goes to the submitter; "
                         "give a key path outside it")
    if key.is_symlink() or (key.exists() and not key.is_file()):
        raise InvalidInputError(f"the score key's path {key} is not a plain file; give another --key")
    if key.exists():
        try:
            is_key = read_manifest(key, follow_kit=False).role == KEY
        except (ManifestError, ValueError):
            is_key = False
        if not is_key:
            raise InvalidInputError(f"{key} exists and is not a score key; give another --key")
        if not overwrite:
            raise InvalidInputError(f"{key} holds the score key of an earlier export; pass --overwrite (overwrite=True) "
                             "to replace it")


def export(
    out: str | os.PathLike,
    source: Any = None,
    protocol: str | OcclusionProtocol = "rect-v1",
    seeds: int | Sequence[int] = (0,),
    *,
    n_frames: int | None = None,
    overwrite: bool = False,
    progress: bool = True,
    trusted: bool = False,
    key: str | os.PathLike | None = None,
) -> Manifest:
    """Write the occluded inputs, hole masks and manifest of every (frame, seed), and the score key.

    The submitter writes one prediction PNG per input at its relative path and may put
    its per-pixel interval beside it (``<name>_low.png`` and ``<name>_high.png``, or
    ``<name>_std.png``; :mod:`.intervals`), which :func:`~.score.score` then scores.

    Parameters
    ----------
    out : path-like
        Folder of the export, the kit that goes to the submitter: new, empty, or (with
        ``overwrite``) an earlier export. A link to a folder is followed (the link stays).
    source : DepthDataset, array-like or None
        Ground truth, as for :func:`~inpaintenv.evaluate.evaluate` (None: the built-in
        SyntheticStreets default). KITTI frames are recorded by file, SyntheticStreets
        by its parameters; any other dataset by the sha256 of each frame (``score`` then
        needs it passed in). Only the score key records them. A source of input kind
        ``"scan"`` exports each frame's scan with the hole cut out as its input, and the
        key records the scans beside the ground truth in the same way.
    protocol : str or OcclusionProtocol
    seeds : int or sequence of int
        Evaluation seeds, distinct non-negative integers; one unless ``trusted``.
    n_frames : int, optional
        Export only the first ``n_frames`` frames.
    overwrite : bool
        Replace an earlier export in ``out`` (only if every file there is one it wrote,
        unchanged) and its score key.
    progress : bool
        A tqdm bar on stderr when it is a terminal.
    trusted : bool
        Allow several seeds: each input then shows the other seeds' holes as measured
        depth, so such an export is for one's own method, never for a submitter.
    key : path-like, optional
        Where the score key goes (default ``<out>.key.json`` beside ``out``); never
        inside ``out``.

    Returns
    -------
    Manifest
        The score key (``path`` is the key; ``root`` the export folder); what the
        submitter gets is ``manifest.kit_manifest()``.

    Raises
    ------
    ValueError
        On a bad ``out`` or key path, seeds (several without ``trusted``), protocol or
        source (``densify-v1`` on maps); an input (the ground truth, or the scan) below
        1/512 m (it would read as 0 = no measurement in KITTI's encoding).
    """
    dataset = resolve_source(source)
    data_root = getattr(dataset, "root", None)  # a folder of files read (KITTI): never written into
    proto = get_protocol(protocol)
    _check_task(proto, dataset.input_kind)
    seed_list = check_seeds(seeds, "seeds")
    if not isinstance(trusted, bool):
        raise InvalidTypeError(f"trusted must be True or False, got {trusted!r}")
    check_one_mask_per_frame(seed_list, trusted)
    total = len(dataset)
    if total == 0:
        raise InvalidInputError("the data source has no frames")
    if n_frames is not None:
        total = min(total, check_int(n_frames, "n_frames", minimum=1))
    if total < len(dataset):
        dataset = Subset(dataset, range(total))
    given = Path(out)
    key_path = Path(os.path.abspath(key)) if key is not None else default_key_path(given)
    if isinstance(data_root, (str, os.PathLike)):
        for path, what in ((given, "--out"), (key_path, "the score key")):
            if is_inside(path, Path(data_root)):
                raise InvalidInputError(f"{what} {path} lies inside the data root {data_root}, which export reads; it "
                                        "never writes there: give a folder outside it")
    # Work on the folder itself: renaming a link to it would replace the link, not the export.
    out = Path(os.path.realpath(given))
    replace = _prepare_out(out, overwrite)
    _prepare_key(key_path, out, overwrite)
    clean_stale(out)
    clean_stale(key_path)
    shape = tuple(int(s) for s in dataset.frame_shape)
    truth, per_frame = describe_truth(dataset)
    parts = frame_parts(dataset.frame_ids, [str(g) for g in dataset.groups])

    remove_stale_temporaries(key_path.parent)
    tmp = _new_folder(out, "partial")
    from tqdm.auto import tqdm  # lazy: only needed when looping

    bar = tqdm(total=total * len(seed_list), desc="export", unit="frame", disable=None if progress else True, leave=False)
    try:
        frames: list[Frame] = []
        by_seed: dict[int, list[Item]] = {s: [] for s in seed_list}
        for i in range(total):
            inputs, gt = _load_frame(dataset, i)
            split, fields = per_frame[i]
            frames.append(_frame_record(dataset, i, fields, inputs, gt))
            for seed in seed_list:
                hole = proto.mask(shape, seed, i)
                input_rel, hole_rel = relative_paths(proto.name, seed, split, parts[i])
                write_depth_png(tmp / input_rel, np.where(hole, np.float32(0), inputs))
                (tmp / hole_rel).parent.mkdir(parents=True, exist_ok=True)
                write_png(tmp / hole_rel, hole.astype(np.uint8) * np.uint8(HOLE_VALUE), "hole mask")
                by_seed[seed].append(Item(
                    seed=seed, index=i, input=input_rel, hole=hole_rel, input_sha256=file_sha256(tmp / input_rel),
                    hole_sha256=file_sha256(tmp / hole_rel), hole_bits_sha256=hole_bits_sha256(hole),
                ))
                bar.update(1)
        manifest = Manifest(
            path=key_path, protocol=protocol_record(proto), seeds=seed_list, frame_shape=shape,  # type: ignore[arg-type]
            ground_truth=truth, frames=frames, items=[it for s in seed_list for it in by_seed[s]],
            inpaintenv_version=__version__,
            extra={"encoding": {"input": DEPTH_ENCODING, "hole": HOLE_ENCODING},
                   # Only an export of scans says so: a map export keeps the bytes it always had.
                   **({"input_kind": dataset.input_kind} if dataset.input.separate else {})},
            role=KEY, kit=Path(os.path.relpath(os.path.abspath(given), key_path.parent)).as_posix(), trusted=trusted,
        )
        manifest.kit_manifest().write(tmp / MANIFEST_NAME)

        def key_then_kit(key_tmp: Path) -> None:
            # The key is complete on disk before the kit moves in, and renamed into place right after.
            manifest.write(key_tmp)
            _install(tmp, out, replace)

        write_atomic(key_path, key_then_kit, "score key")
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    finally:
        bar.close()
    return manifest
