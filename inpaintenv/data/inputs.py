"""What a method is given for a frame: one record per input kind (the map, a scan, a thinned scan).

Every dataset has an ``input_kind``, the name of an :class:`InputKind` (:func:`input_kind`
gives the record; :data:`INPUTS` lists them):

* ``"map"`` (the default): the method's input is the ground-truth map with holes cut
  into it; the input of frame ``i`` *is* frame ``i``; the hole is scored.
* ``"scan"``: the input is a separate single LiDAR scan of the same frame (KITTI's
  ``velodyne_raw``); the ground-truth map is only the target; every pixel left to fill is scored.
* the **density variants** of a scan, a sparser LiDAR simulated from the 64-beam scan
  (:mod:`inpaintenv.data.thinning`), each versioned and seeded:
  ``scan-rings32-v1`` / ``scan-rings16-v1`` / ``scan-rings8-v1`` keep every 2nd / 4th /
  8th laser ring (32 / 16 / 8 beams), ``scan-points50-v1`` / ``scan-points25-v1`` /
  ``scan-points10-v1`` a random 50 / 25 / 10 % of the scan's points, drawn from the
  variant's name and the frame's id (any order, subset or process keeps the same points).

A variant composes with every hole protocol: the hole is cut into the thinned scan.
Adding a kind is one entry of :data:`INPUTS` (and its thinning, if new).

:class:`InputsMixin` gives :class:`~inpaintenv.data.base.DepthDataset` the methods that
load inputs (checked like frames, thinned as their kind says) and input/target pairs.
"""

from __future__ import annotations

import zlib
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..conventions import check_depth, check_seeds
from ..exceptions import InvalidInputError, OutOfRangeError

if TYPE_CHECKING:
    from .calibration import Calibration

__all__ = ["INPUTS", "INPUT_KINDS", "InputKind", "InputsMixin", "check_input_kind", "input_kind", "method_input"]


@dataclass(frozen=True)
class InputKind:
    """One kind of input: what a method is given, which pixels are scored, how rows and files name it.

    Attributes
    ----------
    name : str
        The name (``--input``, ``input=``), written as the rows' ``input_kind``.
    separate : bool
        The input is a separate measurement (a LiDAR scan), not the ground truth with the
        hole cut: every pixel not measured after the hole is cut is to fill and scored.
    keep_every : int
        Keep every ``keep_every``-th laser ring of the scan (1: all).
    keep_fraction : float
        Keep this seeded share of the scan's points (1.0: all).
    beams : int or None
        The beams of the LiDAR it simulates (64 for KITTI's scan), None for a map.
    summary : str
        What a method is given, in words (``inpaintenv info``).
    """

    name: str
    separate: bool
    keep_every: int = 1
    keep_fraction: float = 1.0
    beams: int | None = None
    summary: str = ""

    @property
    def is_map(self) -> bool:
        """The input is the ground truth with the hole cut (the name ``"map"``)."""
        return not self.separate

    @property
    def thinned(self) -> bool:
        """A density variant: fewer rings or points than the scan."""
        return self.keep_every > 1 or self.keep_fraction < 1.0

    @property
    def density(self) -> str:
        """The density in words: ``"64 beams"``, ``"16 beams"``, ``"25 % of points"``, ``"map"``."""
        if not self.separate:
            return "map"
        return f"{round(self.keep_fraction * 100)} % of points" if self.keep_fraction < 1.0 else f"{self.beams} beams"

    def label(self, protocol: str) -> str:
        """What a task of this input under ``protocol`` is called: ``"rect-v1"``, ``"scan:rect-v1"``."""
        return protocol if self.is_map else f"{self.name}:{protocol}"

    @property
    def file_tag(self) -> str:
        """What files of this input add to their name: ``""`` for maps, ``"__scan"``, ``"__scan-rings16-v1"``."""
        return "" if self.is_map else f"__{self.name}"

    def scored(self, x: np.ndarray, hole: np.ndarray) -> np.ndarray:
        """The pixels scored, given the method's input ``x`` (NaN = to fill) and the protocol's ``hole``."""
        return np.isnan(x) if self.separate else hole

    def point_seed(self, frame_id: str) -> int:
        """The seed of a frame's random points: from the kind's name and the frame's id only."""
        return zlib.crc32(f"{self.name}/{frame_id}".encode())


def _rings(beams: int) -> InputKind:
    k = 64 // beams
    nth = {2: "2nd", 3: "3rd"}.get(k, f"{k}th")
    return InputKind(f"scan-rings{beams}-v1", True, keep_every=k, beams=beams,
                     summary=f"the scan with every {nth} laser ring kept ({beams} of 64 beams) and the hole cut")


def _points(percent: int) -> InputKind:
    return InputKind(f"scan-points{percent}-v1", True, keep_fraction=percent / 100, beams=64,
                     summary=f"a seeded random {percent} % of the scan's points with the hole cut")


#: Every input kind, by name (the map first, then the scan and its density variants).
INPUTS: dict[str, InputKind] = {k.name: k for k in (
    InputKind("map", False, summary="the ground-truth map with the protocol's hole cut, the default"),
    InputKind("scan", True, beams=64, summary="the frame's single LiDAR scan with the hole cut (--input scan; KITTI's "
              "velodyne_raw, simulated for the synthetic streets); every pixel left to fill is scored"),
    _rings(32), _rings(16), _rings(8), _points(50), _points(25), _points(10),
)}
#: The names of the input kinds a dataset can have.
INPUT_KINDS: tuple[str, ...] = tuple(INPUTS)


def input_kind(value: object, name: str = "input") -> InputKind:
    """The :class:`InputKind` named ``value`` (or ``value`` itself if it is one), else one clear error."""
    return _as_kind(value, name)


def _as_kind(value: object, name: str) -> InputKind:
    if isinstance(value, InputKind):
        return value
    if not isinstance(value, str) or value not in INPUTS:
        raise InvalidInputError(f"{name} must be one of {', '.join(INPUT_KINDS)}; got {value!r}")
    return INPUTS[value]


def check_input_kind(value: object, name: str = "input") -> str:
    """``value`` if it names an input kind, else one clear error naming the choices.

    Raises
    ------
    InvalidInputError
        If ``value`` is not one of :data:`INPUT_KINDS`.
    """
    return input_kind(value, name).name


def method_input(inputs: np.ndarray, hole: np.ndarray, input_kind: str | InputKind) -> np.ndarray:
    """What a method is given: ``inputs`` with the hole cut out, NaN wherever it is to fill.

    Parameters
    ----------
    inputs : numpy.ndarray
        The measured inputs (:meth:`InputsMixin.load_input_batch`), ``(H, W)`` or ``(N, H, W)``.
    hole : numpy.ndarray
        Boolean mask of the same shape.
    input_kind : str or InputKind
        For a map the hole becomes NaN and a 0 (no measurement) elsewhere stays 0, as
        always; for a scan (and its variants) every pixel not measured after the hole was cut is NaN.

    Returns
    -------
    numpy.ndarray
        float32, a new array.
    """
    if _as_kind(input_kind, "input_kind").is_map:
        x = np.array(inputs, dtype=np.float32)
        x[hole] = np.nan
        return x
    return np.where((inputs > 0) & ~hole, inputs, np.nan).astype(np.float32, copy=False)


class InputsMixin:
    """Loading of a dataset's inputs and of input/target pairs (see the module docstring).

    A dataset whose inputs are scans implements :meth:`_load_scan` (and may implement
    :meth:`_load_scan_pair` to produce both at once); for the ring-thinned kinds also
    :meth:`_scan_calibration` (read through the public :meth:`scan_calibration`). The thinning its kind asks for is applied here.
    """

    #: The name of the dataset's :class:`InputKind`: ``"map"`` (the input is the ground truth), ``"scan"``, ...
    input_kind: str = "map"

    @property
    def input(self) -> InputKind:
        """The record of the dataset's input kind."""
        return _as_kind(self.input_kind, "input_kind")

    def _load_scan(self, index: int) -> np.ndarray:
        """The full scan of frame ``index`` (0 <= index < len), before any thinning."""
        raise NotImplementedError(f"{type(self).__name__} has no scans")

    def _load_scan_pair(self, index: int) -> tuple[np.ndarray, np.ndarray]:
        """``(full scan, ground truth)`` of frame ``index``."""
        return self._load_scan(index), self._load(index)  # type: ignore[attr-defined]

    def scan_calibration(self, index: int) -> tuple[Calibration, float | None]:
        """The projection frame ``index``'s scan was made with, and its lasers' height (None: KITTI's HDL-64E).

        What :func:`~inpaintenv.data.thinning.thin_scan_by_rings` needs to keep every k-th laser
        ring of the frame's scan (``thin_scan_by_rings(scan, calibration, k, laser_height=height)``).

        Returns
        -------
        (Calibration, float or None)

        Raises
        ------
        IndexError
            If ``index`` is out of range (negative indices count from the end).
        InvalidInputError
            If the dataset has no calibration of its scans (its source does not record one).
        """
        return self._scan_calibration(self._frame_index(index))

    def _scan_calibration(self, index: int) -> tuple[Calibration, float | None]:
        """:meth:`scan_calibration` of a valid index (the hook a source of scans implements)."""
        raise InvalidInputError(
            f"{type(self).__name__} has no calibration of its scans: the input kind {self.input_kind!r} finds laser "
            "rings from it; use a KITTI or synthetic source, or a points variant (scan-points25-v1)")

    def _thin(self, index: int, scan: np.ndarray) -> np.ndarray:
        """``scan`` thinned as the dataset's input kind says (itself for the map and the full scan)."""
        kind = self.input
        if kind.keep_every > 1:
            # The rings of a frame are found once (about 0.5 s a KITTI frame): every method and seed of a run
            # reads its input again. Kept as the packed mask of the pixels kept, 1 bit a pixel.
            cache: dict[int, np.ndarray] = self.__dict__.setdefault("_kept_rings", {})
            if index not in cache:
                from .thinning import thin_scan_by_rings  # noqa: PLC0415 - the thinning is only for its variants

                calibration, height = self._scan_calibration(index)
                cache[index] = np.packbits(thin_scan_by_rings(scan, calibration, kind.keep_every, laser_height=height) > 0)
            kept = np.unpackbits(cache[index], count=scan.size).reshape(scan.shape).astype(bool)
            scan = np.where(kept, scan, np.zeros_like(scan))
        if kind.keep_fraction < 1.0:
            from .thinning import thin_scan_by_points  # noqa: PLC0415

            scan = thin_scan_by_points(scan, kind.keep_fraction, kind.point_seed(self.frame_ids[index]))  # type: ignore[attr-defined]
        return scan

    def _load_input(self, index: int) -> np.ndarray:
        """The input of frame ``index`` (0 <= index < len); the frame itself for ``"map"``."""
        if self.input.is_map:
            return self._load(index)  # type: ignore[attr-defined]
        return self._thin(index, self._load_scan(index))

    def _load_pair(self, index: int) -> tuple[np.ndarray, np.ndarray]:
        """``(input, ground truth)`` of frame ``index``."""
        if self.input.is_map:
            frame = self._load(index)  # type: ignore[attr-defined]
            return frame, frame
        scan, truth = self._load_scan_pair(index)
        return self._thin(index, scan), truth

    def checked_input(self, index: int, name: str) -> np.ndarray:
        """Input ``index`` checked like a frame (depth convention, the dataset's frame shape).

        Raises
        ------
        ValueError
            If the input is NaN/inf, negative, above ``DEPTH_LIMIT``, or not ``frame_shape``.
        """
        if self.input.is_map:
            return self.checked_frame(index, name)  # type: ignore[attr-defined]
        return self._check_shape(check_depth(self._load_input(index), name=name, ndim=(2,)), name)

    def _check_shape(self, frame: np.ndarray, name: str) -> np.ndarray:
        if frame.shape != tuple(self.frame_shape):  # type: ignore[attr-defined]
            # Assigning it into a batch would broadcast e.g. a (1, W) frame without a word.
            raise InvalidInputError(
                f"{name} has shape {frame.shape}, the dataset says {tuple(self.frame_shape)}"  # type: ignore[attr-defined]
            )
        return frame

    def input_frame(self, index: int) -> np.ndarray:
        """The measured input of frame ``index``, float32 ``(H, W)`` metres, 0 = no data.

        For input kind ``"map"`` this is the frame itself; for a scan the frame's scan, thinned as its kind says.

        Raises
        ------
        IndexError
            If ``index`` is out of range (negative indices count from the end).
        """
        i = self._frame_index(index)
        return self.checked_input(i, self._input_name(i))

    def _frame_index(self, index: int) -> int:
        """``index`` in ``[0, len)`` (negative counts from the end), or one :class:`OutOfRangeError`."""
        n = len(self)  # type: ignore[arg-type]
        if isinstance(index, bool) or not isinstance(index, (int, np.integer)):
            raise OutOfRangeError(f"a frame index must be an integer, got {index!r}")
        if not -n <= int(index) < n:
            raise OutOfRangeError(f"frame index {int(index)} out of range for a dataset of {n} frames")
        return int(index) % n

    def _input_name(self, i: int) -> str:
        what = "frame" if self.input.is_map else "scan"
        return f"{what} of frame {i} ({self.frame_ids[i]})"  # type: ignore[attr-defined]

    def load_input_batch(self, indices: Sequence[int] | np.ndarray) -> np.ndarray:
        """The measured inputs of several frames as one ``(N, H, W)`` float32 array.

        The same frames as :meth:`load_batch` for input kind ``"map"``; the scans for ``"scan"``.

        Raises
        ------
        TypeError, ValueError
            As :meth:`load_batch`, naming the frame whose input is bad.
        """
        if self.input.is_map:
            return self.load_batch(indices)  # type: ignore[attr-defined]
        idx = check_seeds(indices, "indices", upper=len(self), distinct=False, allow_empty=True)  # type: ignore[arg-type]
        out = np.empty((len(idx), *self.frame_shape), dtype=np.float32)  # type: ignore[attr-defined]
        for k, i in enumerate(idx):
            out[k] = self.checked_input(int(i), self._input_name(int(i)))
        return out

    def load_pairs(self, indices: Sequence[int] | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Inputs and ground truth of several frames in one call: ``(inputs, gt)``, each ``(N, H, W)``.

        For input kind ``"map"`` ``inputs`` *is* ``gt`` (one array, loaded once); a source
        of scans may produce both from one read or render (:meth:`_load_pair`).

        Raises
        ------
        TypeError, ValueError
            As :meth:`load_batch`, naming the frame whose input or truth is bad.
        """
        if self.input.is_map:
            gt = self.load_batch(indices)  # type: ignore[attr-defined]
            return gt, gt
        idx = check_seeds(indices, "indices", upper=len(self), distinct=False, allow_empty=True)  # type: ignore[arg-type]
        inputs = np.empty((len(idx), *self.frame_shape), dtype=np.float32)  # type: ignore[attr-defined]
        gt = np.empty_like(inputs)
        for k, i in enumerate(idx):
            scan, truth = self._load_pair(int(i))
            inputs[k] = self._check_shape(check_depth(scan, name=self._input_name(int(i)), ndim=(2,)),
                                          self._input_name(int(i)))
            name = f"frame {int(i)} ({self.frame_ids[int(i)]})"  # type: ignore[attr-defined]
            gt[k] = self._check_shape(check_depth(truth, name=name, ndim=(2,)), name)
        return inputs, gt
