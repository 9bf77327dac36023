"""``manifest.json``: what an export holds and what it was made from.

An export's manifest records the protocol (name, version and full description), the
seeds, the frame shape (and the crop of KITTI frames), every frame (its position, which
seeds its masks, its id and drive, the ground truth it came from with that file's
sha256), and every exported file with its sha256 and the sha256 of the hole mask's bits.
It never records a time or an absolute path, so exporting the same frames twice gives the
same bytes, and the KITTI root may move between ``export`` and ``score``.
"""

from __future__ import annotations

import json
import os
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from ..data.io import read_depth_png
from .layout import HOLE_VALUE

__all__ = ["FORMAT", "FORMAT_VERSION", "MANIFEST_NAME", "Frame", "Item", "Manifest", "ManifestError", "read_manifest"]

FORMAT = "inpaintenv-submission"
#: Bumped when the manifest's fields or the layout change.
FORMAT_VERSION = 1
MANIFEST_NAME = "manifest.json"


class ManifestError(ValueError):
    """A manifest cannot be read, or does not match the protocol or ground truth here."""


@dataclass(frozen=True)
class Frame:
    """One exported frame.

    Attributes
    ----------
    index : int
        Position in the exported source; with the seed it draws the mask, as in ``evaluate``.
    frame_id, drive : str
        As in the rows of ``evaluate``.
    ground_truth_sha256 : str
        sha256 of the ground-truth file (KITTI) or of the float32 frame (other sources).
    ground_truth : str or None
        The ground-truth file relative to the KITTI root (KITTI sources only).
    position : int or None
        Position in the generated source (SyntheticStreets only).
    """

    index: int
    frame_id: str
    drive: str
    ground_truth_sha256: str
    ground_truth: str | None = None
    position: int | None = None


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
    """A parsed ``manifest.json``.

    Attributes
    ----------
    path : pathlib.Path
        The manifest file; the exported files are relative to its folder (:attr:`root`).
    protocol : dict
        ``name``, ``version`` and ``description`` (``OcclusionProtocol.describe()``).
    seeds : list of int
    frame_shape : tuple of int
    ground_truth : dict
        How the frames were read: ``type`` (``kitti``, ``synthetic`` or ``custom``) and
        what rebuilds them (crop and kind; the generator's parameters; a description).
    frames : list of Frame
    items : list of Item
        Seed-major: every frame of the first seed, then the next seed.
    inpaintenv_version : str
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

    @property
    def root(self) -> Path:
        """The export folder (holding the manifest)."""
        return self.path.parent

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
        mask = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        if mask is None:
            raise FileNotFoundError(f"hole mask {path} is missing or unreadable")
        return mask == HOLE_VALUE

    def to_dict(self) -> dict[str, Any]:
        """The JSON document (what :meth:`write` stores)."""
        return {
            "format": FORMAT,
            "format_version": FORMAT_VERSION,
            "inpaintenv_version": self.inpaintenv_version,
            "protocol": self.protocol,
            "seeds": list(self.seeds),
            "frame_shape": list(self.frame_shape),
            "ground_truth": self.ground_truth,
            **self.extra,
            "frames": [{k: v for k, v in asdict(f).items() if v is not None} for f in self.frames],
            "items": [asdict(i) for i in self.items],
        }

    def write(self, path: str | os.PathLike | None = None) -> Path:
        """Write the manifest (to :attr:`path` by default); returns the path written."""
        target = Path(path) if path is not None else self.path
        target.write_text(json.dumps(self.to_dict(), indent=1) + "\n")
        return target


def read_manifest(path: str | os.PathLike) -> Manifest:
    """Read an export's ``manifest.json`` (or the export folder holding it).

    Raises
    ------
    FileNotFoundError
        If there is no manifest at ``path``.
    ManifestError
        If the file is not an inpaintenv manifest, is of another format version, or lacks
        a field (the message names it).
    """
    p = Path(path)
    if p.is_dir():
        p = p / MANIFEST_NAME
    if not p.is_file():
        raise FileNotFoundError(f"no manifest at {p}; give the manifest.json written by `inpaintenv export`")
    try:
        doc = json.loads(p.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ManifestError(f"{p} is not valid JSON ({exc})") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise ManifestError(f"{p} is not an inpaintenv export manifest (no \"format\": \"{FORMAT}\")")
    if doc.get("format_version") != FORMAT_VERSION:
        raise ManifestError(
            f"{p} has format version {doc.get('format_version')!r}; this inpaintenv reads version "
            f"{FORMAT_VERSION}: export again with this version"
        )
    if not isinstance(doc.get("protocol"), dict) or "name" not in doc["protocol"]:
        raise ManifestError(f"{p} lacks the protocol's name")
    try:
        frames = [Frame(**f) for f in doc["frames"]]
        items = [Item(**i) for i in doc["items"]]
        known = {"format", "format_version", "inpaintenv_version", "protocol", "seeds", "frame_shape",
                 "ground_truth", "frames", "items"}
        manifest = Manifest(
            path=p, protocol=dict(doc["protocol"]), seeds=[int(s) for s in doc["seeds"]],
            frame_shape=(int(doc["frame_shape"][0]), int(doc["frame_shape"][1])),
            ground_truth=dict(doc["ground_truth"]), frames=frames, items=items,
            inpaintenv_version=str(doc["inpaintenv_version"]), extra={k: v for k, v in doc.items() if k not in known},
        )
    except KeyError as exc:
        raise ManifestError(f"{p} lacks the field {exc.args[0]!r}") from None
    except (TypeError, ValueError, IndexError) as exc:
        raise ManifestError(f"{p} has a malformed entry ({exc})") from None
    if [f.index for f in frames] != list(range(len(frames))) or not frames:
        raise ManifestError(f"{p}: frames must be listed by position 0..N-1")
    return manifest
