"""The ground truth behind an export: recorded at ``export``, rebuilt and checked at ``score``.

* KITTI frames are recorded by their file (relative to the KITTI root) and that file's
  sha256; ``score`` reads exactly those files from the root it is given
  (:class:`ManifestFrames`), so no directory scan is needed and a changed or missing file
  is named.
* SyntheticStreets frames are recorded by the generator's parameters and the frame's
  position; the sha256 is of the generated float32 frame.
* Any other dataset (Python only) is recorded by the sha256 of each float32 frame;
  ``score`` then needs the same dataset passed in.

An export of scans (input kind ``"scan"``) records each frame's scan the same way beside
its ground truth: the scan file and its sha256 (KITTI), or the generator's parameters with
``"input": "scan"`` and the sha256 of the float32 scan (other sources).

All of it goes into the score key only, never into the kit. A KITTI file, ground truth
or scan, must resolve inside the root it is read from: a key naming one elsewhere is
refused before the file is touched, so not even its hash is printed.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from ..data.base import ConcatDataset, DepthDataset, Subset
from ..data.io import depth_from_uint16, read_depth_png_raw
from ..data.calibration import Calibration
from ..data.kitti import KittiDepth, bottom_center_crop, png_header, scan_calibration
from ..data.synthetic import SyntheticStreets
from .layout import array_sha256, file_sha256, is_inside
from .manifest import Frame, Manifest, ManifestError
from ..exceptions import InvalidInputError

__all__ = ["ManifestFrames", "describe_truth", "open_truth", "verify_frame"]

ARRAY_HASH = "sha256 of the float32 frame in metres, C order"
#: Most frames a synthetic score key may ask the generator for (its ids are built for every frame).
MAX_SYNTHETIC_FRAMES = 1_000_000


def _leaves(ds: DepthDataset) -> list[tuple[DepthDataset, int]]:
    """``(dataset, position)`` each frame of ``ds`` is read from, through subsets and concatenations."""
    if isinstance(ds, Subset):
        parent = _leaves(ds.parent)
        return [parent[int(i)] for i in ds.indices]
    if isinstance(ds, ConcatDataset):
        return [leaf for part in ds.parts for leaf in _leaves(part)]
    return [(ds, i) for i in range(len(ds))]


def _synthetic_params(ds: SyntheticStreets) -> dict[str, Any]:
    params = {"n": ds.n, "seed": ds.seed, "kind": ds.kind, "frame_shape": list(ds.frame_shape),
              "frames_per_drive": ds.frames_per_drive}
    return {**params, "input": ds.input_kind} if ds.input.separate else params  # a map key keeps its bytes


def _input_record(dataset: DepthDataset) -> dict[str, Any]:
    """``{"input": "scan"}`` for a source of scans (what the key's ``ground_truth`` adds), else nothing."""
    return {"input": dataset.input_kind} if dataset.input.separate else {}


def _kitti_fields(owner: KittiDepth, i: int) -> dict[str, Any]:
    """The score key's record of KITTI frame ``i`` of ``owner``: its ground-truth file (and scan file) and sha256."""
    fields = {"ground_truth": owner.paths[i].relative_to(owner.root).as_posix(),
              "ground_truth_sha256": file_sha256(owner.paths[i], "ground-truth file")}
    if owner.input.separate:
        scan = owner.input_paths[i]
        fields.update(scan=scan.relative_to(owner.root).as_posix(), scan_sha256=file_sha256(scan, "scan file"))
    return fields


def describe_truth(dataset: DepthDataset) -> tuple[dict[str, Any], list[tuple[str, dict[str, Any]]]]:
    """How ``dataset``'s frames are rebuilt: the manifest's ``ground_truth`` and, per frame,
    ``(split, fields)`` where ``fields`` go into its :class:`~.manifest.Frame` (all but the sha256
    of generated frames, which the exporter computes from the frame it loads).
    """
    leaves = _leaves(dataset)
    owners = {id(owner): owner for owner, _ in leaves}
    if all(isinstance(o, KittiDepth) for o in owners.values()):
        crops = {o.crop for o in owners.values()}
        kinds = {o.kind for o in owners.values()}
        if len(crops) == 1 and len(kinds) == 1:
            crop = crops.pop()
            record = {"type": "kitti", "kind": kinds.pop(), "crop": None if crop is None else list(crop),
                      "hash": "sha256 of the ground-truth PNG file", **_input_record(dataset)}
            return record, [(owner.split, _kitti_fields(owner, i)) for owner, i in leaves]
    if all(isinstance(o, SyntheticStreets) for o in owners.values()):
        params = {repr(_synthetic_params(o)) for o in owners.values()}
        if len(params) == 1:
            owner = next(iter(owners.values()))
            record = {"type": "synthetic", **_synthetic_params(owner), "hash": ARRAY_HASH}
            return record, [("synthetic", {"position": i}) for _, i in leaves]
    record = {"type": "custom", "description": repr(dataset), "hash": ARRAY_HASH, **_input_record(dataset)}
    return record, [("custom", {}) for _ in leaves]


class ManifestFrames(DepthDataset):
    """The KITTI ground truth an export lists, read from ``root`` and checked file by file.

    Frames come in the manifest's order, so a frame's position (which seeds its mask) is
    the one it had when exported.

    Parameters
    ----------
    manifest : Manifest
        A manifest of a KITTI export.
    root : path-like
        The KITTI root holding the listed files (it may differ from the export's).

    Raises
    ------
    FileNotFoundError
        If ``root`` is not a folder.
    """

    def __init__(self, manifest: Manifest, root: str | os.PathLike):
        self.root = Path(root).expanduser()
        if not self.root.is_dir():
            raise FileNotFoundError(f"KITTI root {self.root} does not exist or is not a folder")
        crop = manifest.ground_truth.get("crop")
        self.crop = None if crop is None else (int(crop[0]), int(crop[1]))
        self.frame_shape = tuple(manifest.frame_shape)  # type: ignore[assignment]
        self.input_kind = manifest.input_kind
        self.groups = np.asarray([f.drive for f in manifest.frames])
        self.frame_ids = [f.frame_id for f in manifest.frames]
        self._frames = list(manifest.frames)
        self._manifest = manifest.path

    def path(self, index: int) -> Path:
        """The ground-truth file of frame ``index``."""
        return self.root / str(self._frames[index].ground_truth)

    def _load(self, index: int) -> np.ndarray:
        frame = self._frames[index]
        return self._read_listed(index, str(frame.ground_truth), str(frame.ground_truth_sha256), "ground truth")

    def _scan_calibration(self, index: int) -> tuple[Calibration, float | None]:
        path = self.root / str(self._frames[index].scan)
        header = png_header(path)
        return scan_calibration(self.root, self.frame_ids[index], (header.width, header.height), self.frame_shape), None

    def _load_scan(self, index: int) -> np.ndarray:
        frame = self._frames[index]
        return self._read_listed(index, str(frame.scan), str(frame.scan_sha256), "scan")

    def _read_listed(self, index: int, rel: str, expected: str, what: str) -> np.ndarray:
        """The file ``rel`` the key lists for frame ``index``, checked against its sha256, cropped as exported."""
        path = self.root / rel
        # Checked before the file is touched: a key naming a file outside the root (through
        # "..", an absolute path or a link) must not learn anything about it, not even its hash.
        if not is_inside(path, self.root):
            raise ManifestError(f"{what} {rel!r} of frame {index} in {self._manifest} leads outside the KITTI root "
                                f"{self.root}; not read")
        if not os.path.lexists(path):  # anything else there (a FIFO) is named by file_sha256
            raise FileNotFoundError(f"{what} {path} listed in {self._manifest} is missing")
        digest = file_sha256(path, "ground-truth file" if what == "ground truth" else f"{what} file")
        if digest != expected:
            raise ManifestError(
                f"{what} {path} is not the file {self._manifest} was exported from (sha256 "
                f"{digest[:12]}…, the manifest says {expected[:12]}…)"
            )
        raw = read_depth_png_raw(path)
        if self.crop is not None:
            raw = bottom_center_crop(raw, self.crop, name=str(path), copy=False)
        return depth_from_uint16(raw)

    def __repr__(self) -> str:
        return f"ManifestFrames(KITTI, {len(self)} frames, frame_shape={self.frame_shape})"


def open_truth(manifest: Manifest, kitti_root: str | os.PathLike | None = None,
               source: DepthDataset | None = None) -> DepthDataset:
    """The ground truth ``manifest`` was exported from, frames in the manifest's order.

    Parameters
    ----------
    manifest : Manifest
    kitti_root : path-like, optional
        Needed for a KITTI export.
    source : DepthDataset, optional
        The dataset a custom (Python) export was made from; checked frame by frame later
        (:func:`verify_frame`).

    Raises
    ------
    ValueError
        If what the export needs is not given.
    """
    kind = manifest.ground_truth.get("type")
    if source is not None:
        from ..data.base import as_dataset

        source = as_dataset(source)
        if len(source) != len(manifest.frames):
            raise ManifestError(f"source has {len(source)} frames, {manifest.path} lists {len(manifest.frames)}")
        if source.input_kind != manifest.input_kind:
            raise ManifestError(f"source has input kind {source.input_kind!r}, {manifest.path} was exported from "
                                f"inputs of kind {manifest.input_kind!r}")
        return source
    if kind == "kitti":
        if kitti_root is None:
            raise InvalidInputError(f"{manifest.path} was exported from KITTI: pass --kitti-root <KITTI root> "
                             "(kitti_root= in Python) or set $INPAINTENV_KITTI_ROOT")
        return ManifestFrames(manifest, kitti_root)
    if kind == "synthetic":
        return Subset(_synthetic_streets(manifest), [int(f.position) for f in manifest.frames])  # type: ignore[arg-type]
    raise ManifestError(f"{manifest.path} was exported from a Python dataset "
                        f"({manifest.ground_truth.get('description')}); score it in Python with "
                        "score(..., source=<that dataset>)")


def _synthetic_streets(manifest: Manifest) -> SyntheticStreets:
    """The generator a synthetic score key describes, every parameter checked and bounded first."""
    gt = manifest.ground_truth

    def fail(key: str, problem: str) -> ManifestError:
        return ManifestError(f"{manifest.path}: ground_truth.{key} {problem}, got {str(gt.get(key))[:80]!r}")

    def integer(key: str, minimum: int, upper: int) -> int:
        value = gt.get(key)
        if isinstance(value, bool) or not isinstance(value, int) or not minimum <= value <= upper:
            raise fail(key, f"must be an integer in {minimum}..{upper:,}")
        return value

    # Bounded before the generator builds an id for every frame; its frame shape is the
    # manifest's, which read_manifest bounded.
    n = integer("n", 1, MAX_SYNTHETIC_FRAMES)
    seed = integer("seed", 0, 2**63 - 1)
    per_drive = integer("frames_per_drive", 1, MAX_SYNTHETIC_FRAMES)
    shape = gt.get("frame_shape")
    if not isinstance(shape, list) or [type(v) for v in shape] != [int, int] or \
            list(shape) != list(manifest.frame_shape):
        raise fail("frame_shape", f"must be the manifest's frame_shape {list(manifest.frame_shape)}")
    if not isinstance(gt.get("kind"), str):
        raise fail("kind", "must be a string")
    if gt.get("input", "map") != manifest.input_kind:  # read_manifest checked it; a Manifest built in Python may not be
        raise fail("input", f"must be the manifest's input kind {manifest.input_kind!r}")
    if any(f.position is None or f.position >= n for f in manifest.frames):
        raise ManifestError(f"{manifest.path}: a frame's position lies outside the generator's {n} frames")
    try:
        return SyntheticStreets(n=n, seed=seed, kind=gt["kind"], frame_shape=tuple(shape), frames_per_drive=per_drive,
                                input=manifest.input_kind)
    except ValueError as exc:
        raise ManifestError(f"{manifest.path}: ground_truth is not a generator of this inpaintenv ({exc})") from None


def verify_frame(manifest: Manifest, frame: Frame, gt: np.ndarray, scan: np.ndarray | None = None) -> None:
    """Check a loaded frame (and, of an export of scans, its scan) of a generated or custom
    source against its recorded sha256.

    KITTI files are checked where they are read (:class:`ManifestFrames`).

    Raises
    ------
    ManifestError
        Naming the frame, if it or its scan differs from the one exported.
    """
    if manifest.ground_truth.get("type") == "kitti":
        return
    checks = [("ground truth", gt, frame.ground_truth_sha256)]
    if manifest.input_kind != "map":
        checks.append(("scan", scan, frame.scan_sha256))
    for what, array, recorded in checks:
        if array is None or array_sha256(np.asarray(array, dtype=np.float32)) != recorded:
            raise ManifestError(
                f"{what} of frame {frame.index} ({frame.frame_id}) differs from the one {manifest.path} "
                "was exported from: score with the data (and inpaintenv version) of the export"
            )
