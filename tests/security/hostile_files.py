"""Hostile files for the entry-point test: PNG and ``.npy`` bombs, nested JSON, FIFOs,
links out of a command's folder, names that are not UTF-8, and a case's folders (:class:`Place`)."""

from __future__ import annotations

import io
import json
import os
import shutil
import struct
import zlib
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from inpaintenv.data import write_depth_png

__all__ = ["BOMB", "DRIVE", "INTERVALS", "MASK_BOMB", "NESTED", "NOT_UTF8", "NPY_BOMB", "ODOMETRY", "RELEASE", "VICTIM",
           "Place", "npy_header", "png", "settable"]

VICTIM = b"the user's own file: nothing may change it\n"
ROOT = Path(__file__).resolve().parents[2]
INTERVALS = ROOT / "estimators" / "pretrained" / "intervals" / "scanline.json"
RELEASE = ROOT / "estimators" / "pretrained" / "kitti-mixed-v1"
NOT_UTF8 = os.fsdecode(b"caf\xe9")  # Latin-1 bytes: not UTF-8, read back as a surrogate escape
DRIVE = "2011_09_26_drive_0001_sync"


def png(width: int, height: int, bit_depth: int = 16, colour: int = 0, pixels: bytes = b"\0" * 64) -> bytes:
    """A PNG whose header declares ``width x height`` (a bomb when large) over a few bytes of data."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    ihdr = struct.pack(">IIBBBBB", width, height, bit_depth, colour, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(pixels)) + chunk(b"IEND", b"")


def npy_header(shape: tuple[int, ...]) -> bytes:
    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": "<f4", "fortran_order": False, "shape": shape})
    return buf.getvalue()


BOMB = png(20000, 20000)  # 16-bit grey: 800 MB of pixels declared in about 100 bytes
MASK_BOMB = png(20000, 20000, colour=6)  # 16-bit RGBA: 3.2 GB
NPY_BOMB = npy_header((60000, 60000))  # 14 GB of float32 declared in 128 bytes
#: A KITTI odometry calib.txt (P0..P3, Tr) with plain pinhole values.
ODOMETRY = "".join(f"P{i}: 500 0 32 0 0 500 16 0 0 0 1 0\n" for i in range(4)) + "Tr: 1 0 0 0 0 1 0 0 0 0 1 0\n"
NESTED = "[" * 100_000 + "]" * 100_000  # 200 kB


@dataclass
class Place:
    """One case's folders: ``work`` is all the command may write; the victim lies outside it."""

    root: Path
    fifos: list[Path] = field(default_factory=list)

    @property
    def work(self) -> Path:
        return self.root / "work"

    @property
    def victim(self) -> Path:
        return self.root / "victim.txt"

    @property
    def victim_dir(self) -> Path:
        return self.root / "victim_dir"

    def outside(self) -> dict[str, bytes]:
        """Every file outside ``work``, by name, with its bytes."""
        return {str(q.relative_to(self.root)): q.read_bytes() for q in sorted(self.root.rglob("*"))
                if q.is_file() and not q.is_symlink() and self.work not in q.parents}

    def fifo(self, path: Path) -> Path:
        path.parent.mkdir(parents=True, exist_ok=True)
        os.mkfifo(path)
        self.fifos.append(path)
        return path

    def link_out(self, path: Path) -> Path:
        """A symbolic link at ``path`` to the victim, outside the command's folder."""
        path.parent.mkdir(parents=True, exist_ok=True)
        path.symlink_to(self.victim)
        return path

    def folder_link_out(self, path: Path) -> Path:
        """A symbolic link at ``path`` to a folder outside the command's folder."""
        path.parent.mkdir(parents=True, exist_ok=True)
        path.symlink_to(self.victim_dir, target_is_directory=True)
        return path

    def write(self, path: Path, data: bytes | str) -> Path:
        path.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(data, str):
            data = data.encode()
        with open(path, "wb") as f:
            f.write(data)
        return path

    def kitti(self, bad: str | None = None) -> Path:
        """A KITTI tree of one good ground-truth frame, plus one ``bad`` one (fifo, bomb, not-utf8)."""
        folder = self.work / "kitti" / "train" / DRIVE / "proj_depth" / "groundtruth" / "image_02"
        rows = np.linspace(40.0, 5.0, 376)[:, None] + np.zeros((1, 1241))
        depth = np.where(np.random.default_rng(0).random(rows.shape) < 0.3, rows, 0.0)
        write_depth_png(folder / "0000000000.png", depth)
        if bad == "fifo":
            self.fifo(folder / "0000000001.png")
        elif bad == "bomb":
            self.write(folder / "0000000001.png", BOMB)
        elif bad == "not-utf8":
            shutil.copy(folder / "0000000000.png", folder / f"{NOT_UTF8}.png")
        return self.work / "kitti"

    def model(self, edit: Callable[[dict], Any] | None = None, name: str = "model") -> Path:
        """A copy of the shipped kitti-mixed-v1 as a model folder, its config changed by ``edit``."""
        folder = self.work / name
        folder.mkdir(parents=True, exist_ok=True)
        shutil.copy(f"{RELEASE}.safetensors", folder / "model.safetensors")
        config = json.loads(Path(f"{RELEASE}.json").read_text())
        if edit is not None:
            edit(config)
        self.write(folder / "config.json", json.dumps(config))
        return folder

    def intervals(self, edit: Callable[[dict], Any]) -> Path:
        """The shipped scanline calibration changed by ``edit``."""
        doc = json.loads(INTERVALS.read_text())
        edit(doc)
        return self.write(self.work / "cal.json", json.dumps(doc))

    def depth(self, name: str = "a.png") -> Path:
        """A small valid KITTI depth PNG to fill."""
        path = self.work / "in" / name
        write_depth_png(path, np.where(np.random.default_rng(1).random((32, 64)) < 0.5, 12.0, 0.0))
        return path


def settable(key: str, value: Any) -> Callable[[dict], None]:
    def edit(doc: dict) -> None:
        target = doc
        *path, last = key.split(".")
        for part in path:
            target = target[part]
        target[last] = value
    return edit
