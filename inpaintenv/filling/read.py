"""Reading one input of a ``fill`` run: its depth (or scan projected), and which pixels to fill."""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..data.calibration import Calibration, read_calibration
from ..data.depth_files import MASK_SUFFIXES, read_depth_file, read_mask_file
from ..data.projection import drop_far_points, project_scan, read_scan
from ..exceptions import InvalidInputError
from ..values.calibration import check_scan_fits
from ..values.points import far_note
from .ledger import file_identity
from .plan import FillJob
from .view import sensor_view

__all__ = ["NO_HOLES", "Holes", "Item", "Reader", "check_box", "message"]

#: The error of an input where nothing marks a pixel to fill.
NO_HOLES = ("nothing marks the pixels to fill: give --holes MASK (a mask file, or a folder of masks by relative "
            "path; nonzero = fill), --box x0,y0,x1,y1 or --missing (every pixel without a measurement), or mark "
            "them NaN in an .npy/.npz (in Python: holes=, boxes=, missing=)")


def check_box(box: Sequence[int]) -> tuple[int, int, int, int]:
    """``(x0, y0, x1, y1)`` as ints with ``0 <= x0 < x1`` and ``0 <= y0 < y1``; one clear error otherwise."""
    values = tuple(box)
    if len(values) != 4 or not all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) for v in values):
        raise InvalidInputError(f"a box is four pixel integers x0,y0,x1,y1, got {box!r}")
    x0, y0, x1, y1 = (int(v) for v in values)
    if not (0 <= x0 < x1 and 0 <= y0 < y1):
        raise InvalidInputError(f"a box x0,y0,x1,y1 needs 0 <= x0 < x1 and 0 <= y0 < y1 (columns x0..x1-1, rows "
                                f"y0..y1-1), got {x0},{y0},{x1},{y1}")
    return x0, y0, x1, y1


def message(job: FillJob, exc: BaseException) -> str:
    """One line naming the file and the problem."""
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if str(job.source) in text else f"{job.source}: {text}"


@dataclass
class Holes:
    """Which pixels of an input to fill: NaN, a mask (file, or folder by relative path), boxes, missing."""

    holes: Path | None = None
    boxes: tuple[tuple[int, int, int, int], ...] = ()
    missing: bool = False
    fill_all: bool = False
    _shared: np.ndarray | None = None

    def given(self) -> bool:
        """Whether anything besides NaN marks pixels to fill."""
        return self.holes is not None or bool(self.boxes) or self.missing

    def _mask_path(self, job: FillJob) -> Path:
        assert self.holes is not None
        found = [p for s in MASK_SUFFIXES if (p := self.holes / job.rel.with_suffix(s)).is_file()]
        if len(found) != 1:
            why = "no mask" if not found else f"{len(found)} masks ({', '.join(p.name for p in found)})"
            raise InvalidInputError(f"{job.source}: {why} for it in {self.holes} (looked for "
                                    f"{', '.join(str(job.rel.with_suffix(s)) for s in MASK_SUFFIXES)})")
        return found[0]

    def identity(self, job: FillJob) -> dict[str, Any]:
        """What marks ``job``'s pixels to fill, for the ledger: the mask file's identity, boxes, missing."""
        out: dict[str, Any] = {"boxes": [list(b) for b in self.boxes], "missing": self.missing,
                               "fill_all": self.fill_all if self.missing else None, "holes": None}
        if self.holes is not None:
            try:
                out["holes"] = file_identity(self._mask_path(job) if self.holes.is_dir() else self.holes)
            except InvalidInputError:
                out["holes"] = file_identity(self.holes)  # no mask for it: its read fails in one line
        return out

    def _mask(self, job: FillJob) -> tuple[np.ndarray, Path]:
        assert self.holes is not None
        if self.holes.is_dir():
            path = self._mask_path(job)
            return read_mask_file(path), path
        if self._shared is None:
            self._shared = read_mask_file(self.holes)
        return self._shared, self.holes

    def fill_mask(self, job: FillJob, depth: np.ndarray) -> np.ndarray:
        """The pixels of ``depth`` (read from ``job``) to fill; errors name the file."""
        fill = np.isnan(depth)
        if self.holes is not None:
            mask, path = self._mask(job)
            if mask.shape != depth.shape:
                raise InvalidInputError(f"{job.source}: the mask {path} is {mask.shape[1]}x{mask.shape[0]}, the "
                                        f"depth map {depth.shape[1]}x{depth.shape[0]} (width x height)")
            fill |= mask
        height, width = depth.shape
        for x0, y0, x1, y1 in self.boxes:
            if x0 >= width or y0 >= height:
                raise InvalidInputError(f"{job.source}: --box {x0},{y0},{x1},{y1} lies outside its {width}x{height} "
                                        "image")
            fill[y0:y1, x0:x1] = True
        if self.missing:  # inside the scan's field of view, unless every pixel is asked for
            unmeasured = depth == 0
            fill |= unmeasured if self.fill_all else unmeasured & sensor_view(depth)
        if not self.given() and not fill.any():
            raise InvalidInputError(f"{job.source}: {NO_HOLES}")
        return fill


@dataclass
class Item:
    """One input on its way through a run: read (depth, pixels to fill, a scan's points) or failed."""

    job: FillJob
    depth: np.ndarray | None = None
    fill: np.ndarray | None = None
    points: np.ndarray | None = None
    error: str | None = None
    route: tuple[str, str] | None = None  # (input kind, method) for a method routed by input kind
    note: str = ""  # what the run says of the input once written (a scan's points left out)


class Reader:
    """Reads the inputs of a run (in the reader thread): depth files, scans with the calibration, masks."""

    def __init__(self, holes: Holes, calibration: Any, size: tuple[int, int] | None, camera: int | None) -> None:
        self.holes = holes
        self._calib_args: tuple[Any, Any, Any] = (calibration, size, camera)
        self._calib: Calibration | Exception | None = None

    def load_calibration(self) -> None:
        """Read the calibration once, before the scans; unreadable, it fails each scan (the others go on)."""
        source, size, camera = self._calib_args
        if source is None:
            self._calib = InvalidInputError("a LiDAR scan needs its calibration: give --calib PATH (a KITTI raw day "
                                            "folder, an odometry calib.txt with --size WxH, or a KITTI-360 "
                                            "calibration folder)")
            return
        try:
            self._calib = (source.with_size(size) if isinstance(source, Calibration)
                           else read_calibration(source, size, camera))
        except (OSError, ValueError) as exc:
            self._calib = exc
            return
        self._calib.image_size()  # an odometry calib.txt without --size: an error in the options, before any file

    def calibration(self, job: FillJob) -> Calibration:
        """The calibration of the run's scans; one error naming ``job``'s file when it is unusable."""
        if isinstance(self._calib, Exception):
            raise type(self._calib)(f"{job.source}: {self._calib}")
        assert self._calib is not None
        return self._calib

    def identity(self, job: FillJob) -> dict[str, Any]:
        """What besides the method makes ``job``'s pixels: its holes and (a scan) the calibration."""
        out = self.holes.identity(job)
        if job.is_scan:
            calib = self._calib if isinstance(self._calib, Calibration) else None
            out["calibration"] = None if calib is None else {
                "matrix": np.asarray(calib.matrix, np.float64).tolist(), "size": list(calib.size or ()),
                "kind": calib.kind, "camera": calib.camera}
        return out

    def prepare(self, job: FillJob) -> Item:
        """Read one input and its mask; errors are kept in the item."""
        try:
            if job.is_scan:
                points = read_scan(job.source)
                calibration = self.calibration(job)
                check_scan_fits(job.source, calibration.kind, calibration.source)
                # Points beyond the PNG limit cannot be stored: left out (counted), neither filled from nor written.
                points, n_far = drop_far_points(points, calibration, str(job.source))
                depth = project_scan(points, calibration)
                return Item(job, depth, self.holes.fill_mask(job, depth), points, note=far_note(n_far))
            depth = read_depth_file(job.source)
            return Item(job, depth, self.holes.fill_mask(job, depth))
        except Exception as exc:  # noqa: BLE001 - any unreadable input is one line, the run goes on
            if os.environ.get("INPAINTENV_TRACEBACK"):
                raise
            return Item(job, error=message(job, exc))
