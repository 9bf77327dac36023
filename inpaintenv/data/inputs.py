"""What a method is given for a frame: the ground-truth map itself, or a separate LiDAR scan.

Every dataset has an ``input_kind``:

* ``"map"`` (the default): the method's input is the ground-truth map with holes cut
  into it; the input of frame ``i`` *is* frame ``i``.
* ``"scan"``: the input is a separate single LiDAR scan of the same frame (KITTI's
  ``velodyne_raw``); the ground-truth map is only the target.

:class:`InputsMixin` gives :class:`~inpaintenv.data.base.DepthDataset` the methods that
load inputs (checked like frames) and input/target pairs.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..conventions import check_depth, check_seeds
from ..exceptions import InvalidInputError, OutOfRangeError

__all__ = ["INPUT_KINDS", "InputsMixin", "check_input_kind", "method_input"]

#: The input kinds a dataset can have.
INPUT_KINDS = ("map", "scan")


def check_input_kind(value: object, name: str = "input") -> str:
    """``value`` if it is an input kind, else one clear error naming the choices.

    Raises
    ------
    InvalidInputError
        If ``value`` is not ``"map"`` or ``"scan"``.
    """
    if not isinstance(value, str) or value not in INPUT_KINDS:
        raise InvalidInputError(f"{name} must be 'map' or 'scan', got {value!r}")
    return value


def method_input(inputs: np.ndarray, hole: np.ndarray, input_kind: str) -> np.ndarray:
    """What a method is given: ``inputs`` with the hole cut out, NaN wherever it is to fill.

    Parameters
    ----------
    inputs : numpy.ndarray
        The measured inputs (:meth:`InputsMixin.load_input_batch`), ``(H, W)`` or ``(N, H, W)``.
    hole : numpy.ndarray
        Boolean mask of the same shape.
    input_kind : {"map", "scan"}
        For ``"map"`` the hole becomes NaN and a 0 (no measurement) elsewhere stays 0, as
        always; for ``"scan"`` every pixel not measured after the hole was cut is NaN.

    Returns
    -------
    numpy.ndarray
        float32, a new array.
    """
    if check_input_kind(input_kind, "input_kind") == "map":
        x = np.array(inputs, dtype=np.float32)
        x[hole] = np.nan
        return x
    return np.where((inputs > 0) & ~hole, inputs, np.nan).astype(np.float32, copy=False)


class InputsMixin:
    """Loading of a dataset's inputs and of input/target pairs (see the module docstring).

    A dataset of input kind ``"scan"`` implements :meth:`_load_input` (and may implement
    :meth:`_load_pair` to produce both at once).
    """

    #: ``"map"`` (the input is the ground truth) or ``"scan"`` (a separate LiDAR scan).
    input_kind: str = "map"

    def _load_input(self, index: int) -> np.ndarray:
        """The input of frame ``index`` (0 <= index < len); the frame itself for ``"map"``."""
        return self._load(index)  # type: ignore[attr-defined]

    def _load_pair(self, index: int) -> tuple[np.ndarray, np.ndarray]:
        """``(input, ground truth)`` of frame ``index``."""
        return self._load_input(index), self._load(index)  # type: ignore[attr-defined]

    def checked_input(self, index: int, name: str) -> np.ndarray:
        """Input ``index`` checked like a frame (depth convention, the dataset's frame shape).

        Raises
        ------
        ValueError
            If the input is NaN/inf, negative, above ``DEPTH_LIMIT``, or not ``frame_shape``.
        """
        if self.input_kind == "map":
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

        For input kind ``"map"`` this is the frame itself; for ``"scan"`` the frame's scan.

        Raises
        ------
        IndexError
            If ``index`` is out of range (negative indices count from the end).
        """
        n = len(self)  # type: ignore[arg-type]
        if isinstance(index, bool) or not isinstance(index, (int, np.integer)):
            raise OutOfRangeError(f"a frame index must be an integer, got {index!r}")
        if not -n <= int(index) < n:
            raise OutOfRangeError(f"frame index {int(index)} out of range for a dataset of {n} frames")
        i = int(index) % n
        return self.checked_input(i, self._input_name(i))

    def _input_name(self, i: int) -> str:
        what = "scan" if self.input_kind == "scan" else "frame"
        return f"{what} of frame {i} ({self.frame_ids[i]})"  # type: ignore[attr-defined]

    def load_input_batch(self, indices: Sequence[int] | np.ndarray) -> np.ndarray:
        """The measured inputs of several frames as one ``(N, H, W)`` float32 array.

        The same frames as :meth:`load_batch` for input kind ``"map"``; the scans for ``"scan"``.

        Raises
        ------
        TypeError, ValueError
            As :meth:`load_batch`, naming the frame whose input is bad.
        """
        if self.input_kind == "map":
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
        if self.input_kind == "map":
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
