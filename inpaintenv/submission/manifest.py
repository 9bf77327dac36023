"""``manifest.json`` and the score key: what an export holds, and what it was made from.

An export writes two manifests of one format. The **kit's** ``manifest.json``, inside the
export folder that goes to the submitter, records the protocol (name, version and full
description), the seeds, the frame shape, every frame (its position, id and drive) and
every exported file with its sha256 and the sha256 of the hole mask's bits -- nothing
that names or rebuilds the ground truth. The **score key** (``<export>.key.json`` beside
the folder by default), which ``score`` reads and the organiser keeps, holds the same and
the ground truth: the KITTI file of each frame with its sha256 and the crop, or the
generator's parameters and each frame's position and sha256. Neither records a time or
an absolute path, so exporting the same frames twice gives the same bytes, and the KITTI
root may move between ``export`` and ``score``.

Every field is checked when read (:func:`read_manifest`): a tampered manifest is one
:class:`ManifestError` naming the file, the field and the value, never a silently
dropped item or a truncated number.
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..data.inputs import INPUTS
from ..data.io import read_depth_png, read_png
from .layout import HOLE_VALUE, MAX_FRAME_PIXELS, is_safe_relative
from ..exceptions import FileTooLargeError, JSONFileError, ManifestError
from ..files import read_json, write_json

__all__ = ["FORMAT", "FORMAT_VERSION", "KEY", "KIT", "MANIFEST_NAME", "MAX_MANIFEST_BYTES", "Frame", "Item",
           "Manifest", "ManifestError", "default_key_path", "read_manifest", "require_key"]

FORMAT = "inpaintenv-submission"
#: Bumped when the manifest's fields or the layout change.
FORMAT_VERSION = 2
MANIFEST_NAME = "manifest.json"
#: ``role`` of the manifest in the export folder (for the submitter; no ground truth).
KIT = "submission-kit"
#: ``role`` of the score key (for ``score``; names the ground truth).
KEY = "score-key"
#: Largest manifest read, in bytes (a manifest of 100,000 frames and two seeds is about 100 MB).
MAX_MANIFEST_BYTES = 256 << 20
#: Largest seed a manifest may hold (the masks are drawn from 64-bit seeds).
MAX_SEED = 2**63 - 1
_SHA256 = re.compile(r"^[0-9a-f]{64}$")


def default_key_path(out: str | os.PathLike) -> Path:
    """Where ``export`` writes the score key of the export folder ``out``: ``<out>.key.json`` beside it."""
    folder = Path(os.path.abspath(out))
    return folder.parent / f"{folder.name}.key.json"


@dataclass(frozen=True)
class Frame:
    """One exported frame.

    Attributes
    ----------
    index : int
        Position in the exported source; with the seed it draws the mask, as in ``evaluate``.
    frame_id, drive : str
        As in the rows of ``evaluate``.
    ground_truth_sha256 : str or None
        sha256 of the ground-truth file (KITTI) or of the float32 frame (other sources);
        in the score key only.
    ground_truth : str or None
        The ground-truth file relative to the KITTI root (KITTI sources, score key only).
    position : int or None
        Position in the generated source (SyntheticStreets, score key only).
    scan_sha256 : str or None
        Of an export of scans: sha256 of the scan file (KITTI) or of the float32 scan
        (other sources); in the score key only.
    scan : str or None
        Of a KITTI export of scans: the scan file relative to the KITTI root (score key only).
    """

    index: int
    frame_id: str
    drive: str
    ground_truth_sha256: str | None = None
    ground_truth: str | None = None
    position: int | None = None
    scan_sha256: str | None = None
    scan: str | None = None


@dataclass(frozen=True)
class Item:
    """One exported (frame, seed): the occluded input and its hole mask.

    ``input`` and ``hole`` are paths relative to the export folder (POSIX); a prediction
    of this item goes to ``<predictions>/<input>``.
    """

    seed: int
    index: int
    input: str
    hole: str
    input_sha256: str
    hole_sha256: str
    hole_bits_sha256: str


@dataclass
class Manifest:
    """A parsed score key or kit manifest.

    Attributes
    ----------
    path : pathlib.Path
        The manifest file.
    protocol : dict
        ``name``, ``version`` and ``description`` (``OcclusionProtocol.describe()``).
    seeds : list of int
    frame_shape : tuple of int
    ground_truth : dict
        How the frames were read (score key only; ``{}`` in a kit): ``type`` (``kitti``,
        ``synthetic`` or ``custom``) and what rebuilds them (crop and kind; the
        generator's parameters; a description); ``"input": "scan"`` when the inputs are
        the frames' scans (:attr:`input_kind`).
    frames : list of Frame
    items : list of Item
        Seed-major: every frame of the first seed, then the next seed.
    inpaintenv_version : str
    role : {"score-key", "submission-kit"}
        :data:`KEY` (what ``score`` reads) or :data:`KIT` (what the submitter gets).
    kit : str or None
        In a score key: the export folder, relative to the key's folder (POSIX).
    trusted : bool
        Exported with several seeds per frame for one's own method (each input shows the
        other seeds' holes), not for a submitter who must not see the truth.
    """

    path: Path
    protocol: dict[str, Any]
    seeds: list[int]
    frame_shape: tuple[int, int]
    ground_truth: dict[str, Any]
    frames: list[Frame]
    items: list[Item]
    inpaintenv_version: str
    extra: dict[str, Any] = field(default_factory=dict)
    role: str = KEY
    kit: str | None = None
    trusted: bool = False

    @property
    def root(self) -> Path:
        """The export folder: the kit's own folder, or the one a score key names."""
        if self.role == KEY and self.kit is not None:
            return Path(os.path.normpath(self.path.parent / self.kit))
        return self.path.parent

    @property
    def input_kind(self) -> str:
        """``"scan"`` if the inputs are the frames' single LiDAR scans, else ``"map"`` (the ground truth)."""
        return str(self.extra.get("input_kind", "map"))

    @property
    def protocol_name(self) -> str:
        """The protocol's name, e.g. ``"rect-v1"`` (the top folder of every exported file)."""
        return str(self.protocol["name"])

    def read_input(self, item: Item) -> np.ndarray:
        """The occluded input of ``item`` in metres, float32 (0 = hole or no measurement)."""
        return read_depth_png(self.root / item.input)

    def read_hole(self, item: Item) -> np.ndarray:
        """The hole mask of ``item``, boolean (True = fill)."""
        path = self.root / item.hole
        return read_png(path, "hole mask") == HOLE_VALUE

    def kit_manifest(self) -> Manifest:
        """The manifest the submitter gets: this one without anything that names or rebuilds the ground truth."""
        frames = [Frame(index=f.index, frame_id=f.frame_id, drive=f.drive) for f in self.frames]
        return replace(self, path=self.root / MANIFEST_NAME, ground_truth={}, frames=frames, role=KIT, kit=None)

    def to_dict(self) -> dict[str, Any]:
        """The JSON document (what :meth:`write` stores)."""
        doc: dict[str, Any] = {
            "format": FORMAT,
            "format_version": FORMAT_VERSION,
            "role": self.role,
            "inpaintenv_version": self.inpaintenv_version,
            "protocol": self.protocol,
            "seeds": list(self.seeds),
            "frame_shape": list(self.frame_shape),
            "trusted": self.trusted,
        }
        if self.role == KEY:
            doc["kit"] = self.kit
            doc["ground_truth"] = self.ground_truth
        doc.update(self.extra)
        doc["frames"] = [{k: v for k, v in asdict(f).items() if v is not None} for f in self.frames]
        doc["items"] = [asdict(i) for i in self.items]
        return doc

    def write(self, path: str | os.PathLike | None = None) -> Path:
        """Write the manifest (to :attr:`path` by default); returns the path written."""
        target = Path(path) if path is not None else self.path
        return write_json(target, self.to_dict(), indent=1)


def require_key(manifest: Manifest) -> Manifest:
    """``manifest`` if it is a score key; a kit's manifest is refused with where its key would be.

    Raises
    ------
    ManifestError
        If ``manifest`` is a submission kit's manifest (it holds no ground truth, by design).
    """
    if manifest.role == KEY:
        return manifest
    key = default_key_path(manifest.root)
    where = f" ({key})" if key.is_file() else " (<export>.key.json beside the export folder by default)"
    raise ManifestError(f"{manifest.path} is the submission kit's manifest, which holds no ground truth; score with "
                        f"the score key export wrote{where}: --manifest <key>")


def is_kit_path(value: str) -> bool:
    """Whether ``value`` may be a score key's ``"kit"``: a normalised relative POSIX path, names after
    any leading ``..`` (a key kept elsewhere with ``export --key``), never absolute, never ``.``."""
    if not value or "\0" in value or "\\" in value or value.startswith("/") or os.path.isabs(value):
        return False
    parts = value.split("/")
    up = 0
    while up < len(parts) and parts[up] == "..":
        up += 1
    return up < len(parts) and all(p not in ("", ".", "..") for p in parts[up:])


def _check_kit_folder(key: Manifest) -> None:
    """The folder a key's ``"kit"`` names, where it exists, holds a submission kit of the same export.

    A kit handed out and deleted leaves nothing to check (the key alone scores); anything else
    there (``"kit": "../../../etc"``) would point the checks that keep ``score``'s run and the
    predictions out of the export at a folder that is none.
    """
    root = key.root
    if not os.path.lexists(root):
        return
    where = f"{key.path}: \"kit\" {key.kit!r} names {os.path.abspath(root)}"
    if not root.is_dir():
        raise ManifestError(f"{where}, which is not a folder; fix the key's \"kit\" (the export folder relative to it)")
    try:
        kit = read_manifest(root / MANIFEST_NAME, follow_kit=False)
    except FileNotFoundError:
        raise ManifestError(f"{where}, which holds no export (no {MANIFEST_NAME}); fix the key's \"kit\" (the export "
                            "folder relative to it) or move that folder") from None
    except ManifestError as exc:
        raise ManifestError(f"{where}, whose {MANIFEST_NAME} is not an export's ({exc})") from None
    if kit.role != KIT or kit.protocol_name != key.protocol_name or \
            sorted(i.input for i in kit.items) != sorted(i.input for i in key.items):
        raise ManifestError(f"{where}, which holds another export (its {MANIFEST_NAME} lists other inputs); fix the "
                            "key's \"kit\" or move that folder")


def read_manifest(path: str | os.PathLike, *, follow_kit: bool = True) -> Manifest:
    """Read a score key, or an export's ``manifest.json`` (or the export folder holding it).

    Every field is checked: seeds and indices are integers (not floats or booleans), every
    item's seed is one of ``seeds`` and its index one of the frames, every (seed, frame)
    is listed once, paths stay inside the export (and the KITTI root), the frame shape
    and crop are two integers of at most :data:`~.layout.MAX_FRAME_PIXELS` pixels. A score
    key's ``"kit"`` is a normalised relative path (:func:`is_kit_path`) and, with
    ``follow_kit``, the folder it names holds this export's kit where it exists.

    Raises
    ------
    FileNotFoundError
        If there is no manifest at ``path``.
    ManifestError
        If the file is not an inpaintenv manifest, is of another format version, is
        larger than :data:`MAX_MANIFEST_BYTES`, or has a missing or bad field (the message
        names the field and the value).
    """
    p = Path(path)
    if p.is_dir():
        p = p / MANIFEST_NAME
    if not os.path.lexists(p):
        raise FileNotFoundError(f"no manifest at {p}; give the score key (<export>.key.json) written by "
                                "`inpaintenv export`")
    try:  # a regular file (no FIFO waited on), bounded in size and nesting, numbers finite
        doc = read_json(p, "manifest", limit=MAX_MANIFEST_BYTES, allow_nan=False)
    except (JSONFileError, FileTooLargeError) as exc:
        raise ManifestError(str(exc)) from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise ManifestError(f"{p} is not an inpaintenv export manifest (no \"format\": \"{FORMAT}\")")
    if doc.get("format_version") != FORMAT_VERSION:
        raise ManifestError(
            f"{p} has format version {doc.get('format_version')!r}; this inpaintenv reads version "
            f"{FORMAT_VERSION}: export again with this version"
        )
    manifest = _Reader(p, doc).manifest()
    if follow_kit and manifest.role == KEY and manifest.kit is not None:
        _check_kit_folder(manifest)
    return manifest


class _Reader:
    """Checks one manifest document field by field; every refusal names ``path`` and the field."""

    def __init__(self, path: Path, doc: dict[str, Any]):
        self.path, self.doc = path, doc

    def fail(self, where: str, problem: str) -> ManifestError:
        return ManifestError(f"{self.path}: {where} {problem}")

    def get(self, key: str, within: dict[str, Any] | None = None, where: str = "") -> Any:
        box = self.doc if within is None else within
        if key not in box:
            raise ManifestError(f"{self.path} lacks the field {where}{key!r}")
        return box[key]

    def integer(self, value: Any, where: str, minimum: int = 0, upper: int | None = None) -> int:
        """``value`` as an int: a JSON integer (not a float, bool or string) in ``[minimum, upper]``."""
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.fail(where, f"must be an integer, got {value!r}")
        if value < minimum or (upper is not None and value > upper):
            bound = f"in {minimum}..{upper:,}" if upper is not None else f">= {minimum}"
            raise self.fail(where, f"must be {bound}, got {value!r}")
        return value

    def text(self, value: Any, where: str, check: Callable[[str], bool] | None = None, what: str = "") -> str:
        if not isinstance(value, str) or (check is not None and not check(value)):
            raise self.fail(where, f"must be {what or 'a string'}, got {str(value)[:80]!r}")
        return value

    def digest(self, value: Any, where: str) -> str:
        return self.text(value, where, lambda v: bool(_SHA256.match(v)), "a sha256 (64 lowercase hex digits)")

    def shape(self, value: Any, where: str) -> tuple[int, int]:
        """A frame shape or crop: a list of two positive integers of at most MAX_FRAME_PIXELS pixels."""
        if not isinstance(value, list) or len(value) != 2:
            raise self.fail(where, f"must be a list of two integers [H, W], got {str(value)[:80]!r}")
        h, w = (self.integer(v, where, minimum=1, upper=MAX_FRAME_PIXELS) for v in value)
        if h * w > MAX_FRAME_PIXELS:
            raise self.fail(where, f"declares {h}x{w} = {h * w:,} pixels, more than the {MAX_FRAME_PIXELS:,} a frame "
                                   "may have")
        return h, w

    def manifest(self) -> Manifest:
        doc = self.doc
        role = self.get("role")
        if role not in (KEY, KIT):
            raise self.fail("role", f"must be {KEY!r} or {KIT!r}, got {str(role)[:80]!r}")
        protocol = self.get("protocol")
        if not isinstance(protocol, dict) or not isinstance(protocol.get("name"), str):
            raise ManifestError(f"{self.path} lacks the protocol's name")
        name = protocol["name"]
        if not re.match(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$", name):
            raise self.fail("protocol.name", f"must be a protocol name, got {name[:80]!r}")
        raw_seeds = self.get("seeds")
        if not isinstance(raw_seeds, list) or not raw_seeds:
            raise self.fail("seeds", f"must be a non-empty list of integers, got {str(raw_seeds)[:80]!r}")
        seeds = [self.integer(s, "seeds", upper=MAX_SEED) for s in raw_seeds]
        if len(set(seeds)) != len(seeds):
            raise self.fail("seeds", f"lists a seed twice: {seeds[:10]}")
        shape = self.shape(self.get("frame_shape"), "frame_shape")
        trusted = self.get("trusted")
        if not isinstance(trusted, bool):
            raise self.fail("trusted", f"must be true or false, got {trusted!r}")
        kit = None
        truth: dict[str, Any] = {}
        if role == KEY:
            kit = self.get("kit")
            if kit is not None:
                self.text(kit, "kit", is_kit_path, "the export folder relative to the key (a normalised relative "
                          "path, no '.' or '..' after a name)")
            truth = self.get("ground_truth")
            if not isinstance(truth, dict) or truth.get("type") not in ("kitti", "synthetic", "custom"):
                raise self.fail("ground_truth", "must be an object whose \"type\" is kitti, synthetic or custom")
            if truth["type"] == "kitti" and truth.get("crop") is not None and \
                    self.shape(truth["crop"], "ground_truth.crop") != shape:
                raise self.fail("ground_truth.crop", f"{truth['crop']} differs from frame_shape {list(shape)}")
        scans = self.input_kind(role, truth)
        frames = self.frames(self.get("frames"), role, truth, scans)
        items = self.items(self.get("items"), name, seeds, len(frames))
        version = self.text(self.get("inpaintenv_version"), "inpaintenv_version")
        known = {"format", "format_version", "role", "inpaintenv_version", "protocol", "seeds", "frame_shape",
                 "trusted", "kit", "ground_truth", "frames", "items"}  # input_kind stays in extra (both roles)
        return Manifest(path=self.path, protocol=dict(protocol), seeds=seeds, frame_shape=shape, ground_truth=truth,
                        frames=frames, items=items, inpaintenv_version=version,
                        extra={k: v for k, v in doc.items() if k not in known}, role=role, kit=kit, trusted=trusted)

    def input_kind(self, role: str, truth: dict[str, Any]) -> bool:
        """Whether the inputs are scans: the document's ``input_kind`` (absent: maps), which a key's
        ``ground_truth.input`` must repeat (it says how to rebuild them)."""
        kind = self.doc.get("input_kind", "map")
        if not isinstance(kind, str) or kind not in INPUTS:
            raise self.fail("input_kind", f"must be one of {', '.join(INPUTS)}, got {str(kind)[:80]!r}")
        if role == KEY and truth.get("input", "map") != kind:
            raise self.fail("ground_truth.input", f"must be the input_kind {kind!r}, got {str(truth.get('input'))[:80]!r}")
        return INPUTS[kind].separate

    def frames(self, raw: Any, role: str, truth: dict[str, Any], scans: bool = False) -> list[Frame]:
        if not isinstance(raw, list) or not raw:
            raise self.fail("frames", "must be a non-empty list")
        kind = truth.get("type")
        frames = []
        for k, f in enumerate(raw):
            where = f"frames[{k}]"
            if not isinstance(f, dict):
                raise self.fail(where, "must be an object")
            extra = set(f) - {"index", "frame_id", "drive", "ground_truth_sha256", "ground_truth", "position",
                              *(("scan_sha256", "scan") if scans and role == KEY else ())}
            if extra:
                raise self.fail(where, f"has unknown fields {sorted(extra)[:3]}")
            index = self.integer(self.get("index", f, f"{where}."), f"{where}.index")
            if index != k:
                raise self.fail(f"{where}.index", f"is {index}: frames must be listed by position 0..N-1")
            frame = Frame(index=index, frame_id=self.text(self.get("frame_id", f, f"{where}."), f"{where}.frame_id"),
                          drive=self.text(self.get("drive", f, f"{where}."), f"{where}.drive"))
            if role == KEY:
                gt_sha = self.digest(self.get("ground_truth_sha256", f, f"{where}."), f"{where}.ground_truth_sha256")
                gt = position = None
                if kind == "kitti":
                    gt = self.text(self.get("ground_truth", f, f"{where}."), f"{where}.ground_truth",
                                   is_safe_relative, "a path relative to the KITTI root, without '..'")
                elif kind == "synthetic":
                    position = self.integer(self.get("position", f, f"{where}."), f"{where}.position")
                frame = replace(frame, ground_truth_sha256=gt_sha, ground_truth=gt, position=position)
                if scans:
                    frame = self.scan_fields(frame, f, where, kind == "kitti")
            elif {"ground_truth", "ground_truth_sha256", "position"} & set(f):
                raise self.fail(where, "names ground truth, which a submission kit's manifest never holds")
            frames.append(frame)
        return frames

    def scan_fields(self, frame: Frame, f: dict[str, Any], where: str, kitti: bool) -> Frame:
        """``frame`` with its scan's sha256 and (KITTI) file, as a score key of scans lists them."""
        scan_sha = self.digest(self.get("scan_sha256", f, f"{where}."), f"{where}.scan_sha256")
        scan = None
        if kitti:
            scan = self.text(self.get("scan", f, f"{where}."), f"{where}.scan", is_safe_relative,
                             "a path relative to the KITTI root, without '..'")
        elif "scan" in f:
            raise self.fail(f"{where}.scan", "names a file, which only a KITTI export does")
        return replace(frame, scan_sha256=scan_sha, scan=scan)

    def items(self, raw: Any, protocol: str, seeds: list[int], n_frames: int) -> list[Item]:
        if not isinstance(raw, list):
            raise self.fail("items", "must be a list")
        items, pairs, paths = [], set(), set()
        for k, it in enumerate(raw):
            where = f"items[{k}]"
            if not isinstance(it, dict):
                raise self.fail(where, "must be an object")
            extra = set(it) - {"seed", "index", "input", "hole", "input_sha256", "hole_sha256", "hole_bits_sha256"}
            if extra:
                raise self.fail(where, f"has unknown fields {sorted(extra)[:3]}")
            seed = self.integer(self.get("seed", it, f"{where}."), f"{where}.seed", upper=MAX_SEED)
            if seed not in seeds:
                raise self.fail(f"{where}.seed", f"is {seed}, which is not one of seeds {seeds[:10]}")
            index = self.integer(self.get("index", it, f"{where}."), f"{where}.index", upper=n_frames - 1)
            if (seed, index) in pairs:
                raise self.fail(where, f"lists frame {index} seed {seed} a second time")
            pairs.add((seed, index))
            prefix = f"{protocol}/seed_{seed}/"
            files = {}
            for key in ("input", "hole"):
                files[key] = self.text(
                    self.get(key, it, f"{where}."), f"{where}.{key}",
                    lambda v: is_safe_relative(v) and v.startswith(prefix) and v.endswith(".png") and v not in paths,
                    f"a distinct .png path under {prefix}")
                paths.add(files[key])
            digests = {key: self.digest(self.get(key, it, f"{where}."), f"{where}.{key}")
                       for key in ("input_sha256", "hole_sha256", "hole_bits_sha256")}
            items.append(Item(seed=seed, index=index, input=files["input"], hole=files["hole"], **digests))
        if len(pairs) != len(seeds) * n_frames:
            absent = sorted((s, i) for s in seeds for i in range(n_frames) if (s, i) not in pairs)
            seed, index = absent[0]
            raise self.fail("items", f"lack {len(absent)} of the {len(seeds) * n_frames} (seed, frame) pairs, first "
                                     f"frame {index} seed {seed}: every frame is exported under every seed")
        return items
