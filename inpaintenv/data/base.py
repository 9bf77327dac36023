"""The dataset interface every data source implements, plus drive-level splits and subsets."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import Any, overload

import numpy as np

from ..conventions import (
    check_depth,
    check_int,
    check_seed,
    check_seeds,
    is_real_number,
)
from ..progress import count
from ..exceptions import InvalidInputError, InvalidTypeError, OutOfRangeError
from .calibration import Calibration
from .inputs import InputsMixin, check_input_kind

__all__ = [
    "DepthDataset", "ArrayDataset", "ConcatDataset", "Subset", "as_dataset", "select_drives",
    "split_by_drive", "subset",
]


class DepthDataset(InputsMixin, Sequence, ABC):
    """A lazy, indexable sequence of ground-truth depth maps of one fixed size.

    Subclasses implement :meth:`_load` and set ``groups`` (one drive id per frame),
    ``frame_ids`` (stable, human-readable ids) and ``frame_shape``.

    Items are ``(H, W)`` float32 metres, 0 = no measurement. Integer indexing loads one
    frame; slices and integer arrays return a :class:`Subset` (nothing is loaded).
    ``input_kind`` says what a method is given: the frame itself (``"map"``) or a separate
    LiDAR scan of it (``"scan"``, see :mod:`inpaintenv.data.inputs`).

    A dataset looks like a lazy ``(N, H, W)`` array to scikit-learn (``shape``,
    ``len``, ``ds[indices, ...]``), so ``GridSearchCV`` and ``cross_validate`` split it
    into lazy subsets that keep their drive ids instead of loading every frame.
    """

    #: ``(H, W)`` of every frame.
    frame_shape: tuple[int, int]
    #: Drive id of each frame: splits and CV folds never put one drive on both sides.
    groups: np.ndarray
    #: A stable id per frame, e.g. ``"2011_09_26_drive_0001_sync/image_02/0000000005"``.
    frame_ids: list[str]

    @abstractmethod
    def _load(self, index: int) -> np.ndarray:
        """Load frame ``index`` (0 <= index < len) as float32 ``(H, W)`` metres."""

    def __len__(self) -> int:
        return len(self.groups)

    @property
    def shape(self) -> tuple[int, int, int]:
        """``(N, H, W)``, as if the dataset were one array."""
        return (len(self), *self.frame_shape)

    @overload
    def __getitem__(self, index: int) -> np.ndarray: ...
    @overload
    def __getitem__(self, index: slice | Sequence[int] | np.ndarray) -> "Subset": ...

    def __getitem__(self, index: Any) -> Any:
        if isinstance(index, tuple):
            # scikit-learn indexes arrays as ``X[key, ...]``.
            if len(index) == 2 and index[1] is Ellipsis:
                index = index[0]
            else:
                raise OutOfRangeError("a dataset is indexed by frame only: ds[i] or ds[indices]")
        if isinstance(index, (int, np.integer)):
            return self._load(self._frame_index(int(index)))
        if isinstance(index, slice):
            return Subset(self, np.arange(len(self))[index])
        return Subset(self, np.asarray(index))

    def load_batch(self, indices: Sequence[int] | np.ndarray) -> np.ndarray:
        """Load several frames as one ``(N, H, W)`` float32 array.

        Parameters
        ----------
        indices : sequence of int
            Frame positions, integers in ``0..len-1`` (repeats allowed; floats refused).

        Returns
        -------
        numpy.ndarray
            ``(N, H, W)`` float32 metres.

        Raises
        ------
        TypeError
            If an index is not an integer.
        ValueError
            If an index is out of range, or a loaded frame breaks the depth convention
            (negative, NaN/inf, above ``DEPTH_LIMIT``) or has the wrong shape; the
            message names the frame, so a bad custom dataset is not blamed on a method.
        """
        idx = check_seeds(indices, "indices", upper=len(self), distinct=False, allow_empty=True)
        out = np.empty((len(idx), *self.frame_shape), dtype=np.float32)
        for k, i in enumerate(idx):
            out[k] = self.checked_frame(i, f"frame {i} ({self.frame_ids[i]})")
        return out

    def checked_frame(self, index: int, name: str) -> np.ndarray:
        """Frame ``index`` after checking the depth convention and the dataset's frame shape.

        Every consumer of a dataset (batches, the environment, training) loads frames
        through this, so a bad custom dataset is reported by ``name`` where it is read,
        not blamed later on a method or a NaN loss.

        Raises
        ------
        ValueError
            If the frame is NaN/inf, negative, above ``DEPTH_LIMIT``, not 2-D or not
            ``frame_shape``.
        """
        frame = check_depth(self[index], name=name, ndim=(2,))
        if frame.shape != tuple(self.frame_shape):
            # Assigning it into a batch would broadcast e.g. a (1, W) frame without a word.
            raise InvalidInputError(f"{name} has shape {frame.shape}, the dataset says {tuple(self.frame_shape)}")
        return frame

    def __array__(self, dtype: Any = None, copy: Any = None) -> np.ndarray:
        arr = self.load_batch(range(len(self)))
        return arr if dtype is None else arr.astype(dtype)

    def summary(self, n_sample: int = 8) -> dict[str, Any]:
        """A description of the dataset (what ``inpaintenv info`` prints).

        Parameters
        ----------
        n_sample : int, default 8
            Number of evenly spaced frames loaded to measure the valid-pixel density
            (0: do not measure).

        Returns
        -------
        dict
            ``source`` (class name), the fields of :meth:`_summary_fields` (e.g. root
            and split of a KITTI dataset), ``frames``, ``drives``, ``frames_per_drive``,
            ``frame_shape``, ``valid_density`` (mean fraction of pixels > 0 over the
            sample, None without one) and ``sampled_frames``.
        """
        if isinstance(n_sample, bool) or not isinstance(n_sample, (int, np.integer)) or n_sample < 0:
            raise InvalidInputError(f"n_sample must be an integer >= 0, got {n_sample!r}")
        drives, counts = np.unique(self.groups, return_counts=True)
        n = min(int(n_sample), len(self))
        sample = np.unique(np.linspace(0, len(self) - 1, num=n).round().astype(int)) if n else np.array([], int)
        return {
            "source": type(self).__name__,
            **self._summary_fields(),
            "frames": len(self),
            "drives": len(drives),
            "frames_per_drive": {str(d): int(c) for d, c in zip(drives, counts)},
            "frame_shape": list(self.frame_shape),
            "valid_density": float(np.mean([(self[int(i)] > 0).mean() for i in sample])) if len(sample) else None,
            "sampled_frames": int(len(sample)),
        }

    info = summary

    def _summary_fields(self) -> dict[str, Any]:
        """Source-specific entries of :meth:`summary` (root, split, seed, ...)."""
        return {}

    def __repr__(self) -> str:
        n_drives = len(np.unique(self.groups)) if len(self) else 0
        scan = f", input={self.input_kind!r}" if self.input_kind != "map" else ""
        return (f"{type(self).__name__}({count(len(self), 'frame')}, {count(n_drives, 'drive')}, "
                f"frame_shape={self.frame_shape}{scan})")


class Subset(DepthDataset):
    """A view of selected frames of another dataset (keeps its groups and ids)."""

    def __init__(self, parent: DepthDataset, indices: Sequence[int] | np.ndarray):
        idx = np.asarray(indices)
        if idx.dtype == bool:
            if idx.shape != (len(parent),):
                raise InvalidInputError("a boolean index must have one entry per frame")
            idx = np.flatnonzero(idx)
        if idx.size and not np.issubdtype(idx.dtype, np.integer):
            raise InvalidTypeError(f"frame indices must be integers, got dtype {idx.dtype}")
        idx = idx.astype(np.int64).reshape(-1)
        n = len(parent)
        if idx.size and (idx.min() < -n or idx.max() >= n):
            raise OutOfRangeError(f"frame indices out of range for a dataset of {n} frames")
        # Flatten nested subsets so loading never walks a chain of views.
        if isinstance(parent, Subset):
            idx = parent.indices[idx % n]
            parent = parent.parent
        self.parent = parent
        self.indices = idx % len(parent) if len(parent) else idx
        self.frame_shape = parent.frame_shape
        self.groups = np.asarray(parent.groups)[self.indices]
        self.frame_ids = [parent.frame_ids[i] for i in self.indices]
        self.input_kind = parent.input_kind

    def _load(self, index: int) -> np.ndarray:
        return self.parent[int(self.indices[index])]

    def _load_input(self, index: int) -> np.ndarray:
        return self.parent._load_input(int(self.indices[index]))

    def _load_pair(self, index: int) -> tuple[np.ndarray, np.ndarray]:
        return self.parent._load_pair(int(self.indices[index]))

    def _scan_calibration(self, index: int) -> tuple[Calibration, float | None]:
        return self.parent._scan_calibration(int(self.indices[index]))


class ArrayDataset(DepthDataset):
    """Wrap an ``(N, H, W)`` array or a list of ``(H, W)`` arrays as a dataset.

    Parameters
    ----------
    frames : array-like or sequence of array-like
        Ground-truth depth maps in metres.
    groups : sequence of str, optional
        Drive id per frame; by default every frame is its own group.
    inputs : array-like or sequence of array-like, optional
        A measured scan per frame (same count and size as ``frames``): the dataset's input
        kind is then ``"scan"`` and ``frames`` is only the target.
    """

    def __init__(self, frames: Any, groups: Sequence[Any] | None = None, inputs: Any = None):
        if isinstance(frames, np.ndarray) or not isinstance(frames, Sequence):
            arr = check_depth(frames, name="frames", ndim=(3,))
            self._frames: Sequence[np.ndarray] | np.ndarray = arr
        else:
            if len(frames) == 0:
                raise InvalidInputError("frames is empty")
            self._frames = [check_depth(f, name=f"frames[{i}]", ndim=(2,)) for i, f in enumerate(frames)]
        shapes = {tuple(f.shape) for f in self._frames}
        if len(shapes) != 1:
            raise InvalidInputError(f"all frames must have one size, got {sorted(shapes)}")
        self.frame_shape = shapes.pop()  # type: ignore[assignment]
        n = len(self._frames)
        if groups is None:
            groups = [f"frame{i}" for i in range(n)]
        if len(groups) != n:
            raise InvalidInputError(f"groups has {len(groups)} entries for {n} frames")
        self.groups = np.asarray([str(g) for g in groups])
        self.frame_ids = [f"{g}/{i}" for i, g in enumerate(self.groups)]
        self._inputs: Any = None
        if inputs is not None:
            scans = check_depth(np.asarray(inputs), name="inputs", ndim=(3,))
            if scans.shape != (n, *self.frame_shape):
                raise InvalidInputError(f"inputs has shape {scans.shape}, the frames {(n, *self.frame_shape)}")
            self._inputs, self.input_kind = scans, "scan"

    def _load(self, index: int) -> np.ndarray:
        return np.asarray(self._frames[index], dtype=np.float32)

    def _load_scan(self, index: int) -> np.ndarray:
        return self._inputs[index]


class ConcatDataset(DepthDataset):
    """Several datasets of one frame size, one after the other (e.g. KITTI train + val).

    Parameters
    ----------
    parts : sequence of DepthDataset
    """

    def __init__(self, parts: Sequence[DepthDataset]):
        if isinstance(parts, DepthDataset) or not isinstance(parts, (list, tuple)):
            raise InvalidTypeError(
                f"ConcatDataset needs a list of datasets, got {type(parts).__name__}"
            )
        if not parts:
            raise InvalidInputError("ConcatDataset needs at least one dataset")
        for k, p in enumerate(parts):
            _require_dataset(p, f"ConcatDataset part {k}")
        shapes = {tuple(p.frame_shape) for p in parts}
        if len(shapes) != 1:
            raise InvalidInputError(f"datasets to concatenate have different frame sizes: {sorted(shapes)}")
        kinds = sorted({p.input_kind for p in parts})
        if len(kinds) != 1:
            raise InvalidInputError(f"datasets to concatenate have different input kinds: {kinds}")
        self.parts = list(parts)
        self.input_kind = check_input_kind(kinds[0], "the parts' input kind")
        self.frame_shape = shapes.pop()  # type: ignore[assignment]
        self.groups = np.concatenate([np.asarray(p.groups) for p in parts])
        self.frame_ids = [f for p in parts for f in p.frame_ids]
        self._offsets = np.cumsum([0] + [len(p) for p in parts])

    def _part(self, index: int) -> tuple[DepthDataset, int]:
        part = int(np.searchsorted(self._offsets, index, side="right")) - 1
        return self.parts[part], int(index - self._offsets[part])

    def _load(self, index: int) -> np.ndarray:
        part, i = self._part(index)
        return part[i]

    def _load_input(self, index: int) -> np.ndarray:
        part, i = self._part(index)
        return part._load_input(i)

    def _load_pair(self, index: int) -> tuple[np.ndarray, np.ndarray]:
        part, i = self._part(index)
        return part._load_pair(i)

    def _scan_calibration(self, index: int) -> tuple[Calibration, float | None]:
        part, i = self._part(index)
        return part._scan_calibration(i)

    def __repr__(self) -> str:
        return f"ConcatDataset({' + '.join(repr(p) for p in self.parts)})"


def name_from_path(name: str) -> str:
    """A file or folder name as a frame id or drive name: bytes that are not UTF-8 become ``\\xNN``.

    Python reads such bytes of a file name as surrogate escapes, which cannot be written
    to a UTF-8 report, table or hash; the id keeps them visible and reversible by eye
    (the file's path itself is kept as the system gave it). Any other name is unchanged.
    """
    return name.encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace")


def select_drives(
    dataset: DepthDataset,
    drives: Sequence[str] | None = None,
    exclude: Sequence[str] | None = None,
) -> DepthDataset:
    """Keep only the frames of ``drives`` and drop those of ``exclude``.

    Raises
    ------
    ValueError
        If a named drive is not in the dataset, ``drives`` is empty, or nothing is left.
    TypeError
        If ``drives`` or ``exclude`` is a single string instead of a list of names.
    """
    for name, value in (("drives", drives), ("exclude", exclude)):
        if isinstance(value, (str, bytes)):
            raise InvalidTypeError(f"{name} must be a list of drive names, got the string {value!r}")
    if drives is not None and len(drives) == 0:
        # "keep only these drives: none" would otherwise silently keep every drive.
        raise InvalidInputError("drives is empty; pass None to keep every drive")
    if not drives and not exclude:
        return dataset
    # Names typed on a command line carry a non-UTF-8 byte as a surrogate escape, drive ids as \xNN.
    drives = None if drives is None else [name_from_path(str(d)) for d in drives]
    exclude = None if exclude is None else [name_from_path(str(d)) for d in exclude]
    known = set(np.asarray(dataset.groups).tolist())
    unknown = sorted({*(drives or ()), *(exclude or ())} - known)
    if unknown:
        raise InvalidInputError(f"unknown drives {unknown}; the dataset has {sorted(known)}")
    keep = np.ones(len(dataset), dtype=bool)
    if drives:
        keep &= np.isin(dataset.groups, list(drives))
    if exclude:
        keep &= ~np.isin(dataset.groups, list(exclude))
    if not keep.any():
        raise InvalidInputError("no frames left after selecting drives")
    return Subset(dataset, np.flatnonzero(keep))


def spaced_per_drive(dataset: DepthDataset, per_drive: int, drives: Sequence[str] | None = None) -> Subset:
    """Up to ``per_drive`` evenly spaced frames of each drive, first and last included.

    So that a check weighs drives alike whatever their length (one KITTI drive may hold twenty
    times another's frames). ``per_drive=0`` keeps every frame.

    Parameters
    ----------
    dataset : DepthDataset
        Frames carrying drive ids (``groups``).
    per_drive : int
        Frames kept per drive (0 = all).
    drives : sequence of str, optional
        The drives, in this order; every drive of ``dataset`` (sorted) by default.

    Raises
    ------
    InvalidInputError
        For a negative ``per_drive`` or a drive the dataset does not have.
    """
    if isinstance(per_drive, bool) or not isinstance(per_drive, (int, np.integer)) or per_drive < 0:
        raise InvalidInputError(f"per_drive must be an integer >= 0 (0 = every frame), got {per_drive!r}")
    groups = np.asarray(dataset.groups)
    drives = sorted(set(groups.tolist())) if drives is None else [str(d) for d in drives]
    idx: list[int] = []
    for d in drives:
        where = np.flatnonzero(groups == d)
        if not where.size:
            raise InvalidInputError(f"unknown drive {d!r}; the dataset has {sorted(set(groups.tolist()))}")
        take = min(per_drive, where.size) if per_drive else where.size
        idx += where[np.linspace(0, where.size - 1, take).astype(int)].tolist()
    return Subset(dataset, np.asarray(idx, dtype=np.int64))


def _require_dataset(dataset: Any, what: str) -> DepthDataset:
    """``dataset`` if it is a DepthDataset, else a TypeError that says how to wrap arrays."""
    if not isinstance(dataset, DepthDataset):
        raise InvalidTypeError(f"{what} must be a DepthDataset, got {type(dataset).__name__}; "
                               "wrap arrays with inpaintenv.data.as_dataset(...)")
    return dataset


def as_dataset(data: Any) -> DepthDataset:
    """Return ``data`` as a :class:`DepthDataset` (datasets pass through unchanged).

    Accepts a dataset, an ``(N, H, W)`` array, a single ``(H, W)`` array, or a sequence
    of ``(H, W)`` arrays.
    """
    if isinstance(data, DepthDataset):
        return data
    if isinstance(data, np.ndarray) and data.ndim == 2:
        # One frame, checked as (H, W): a single frame may be any size, while an
        # (N, H, W) batch's frames must be at least MIN_FRAME_SIDE (check_depth).
        return ArrayDataset([check_depth(data, name="frames", ndim=(2,))])
    return ArrayDataset(data)


def split_by_drive(
    dataset: DepthDataset, test_size: float | int = 0.2, seed: int = 0
) -> tuple[Subset, Subset]:
    """Split a dataset into train and test so that no drive appears on both sides.

    Parameters
    ----------
    dataset : DepthDataset
    test_size : float or int
        Fraction of drives (float in (0, 1)) or number of drives (int) for the test side.
        At least one drive goes to each side.
    seed : int
        Seed of the drive shuffle; the same seed always gives the same split.

    Returns
    -------
    train, test : Subset

    Raises
    ------
    TypeError
        If ``dataset`` is not a DepthDataset, ``test_size`` is not a number or
        ``seed`` is not a non-negative integer.
    ValueError
        If the dataset has fewer than 2 drives or a fractional ``test_size`` is
        outside (0, 1).
    """
    _require_dataset(dataset, "split_by_drive's dataset")
    seed = check_seed(seed, "seed")
    drives = np.unique(dataset.groups)
    if len(drives) < 2:
        raise InvalidInputError(f"a drive-level split needs at least 2 drives, the dataset has {len(drives)}")
    if isinstance(test_size, (float, np.floating)):
        if not 0.0 < test_size < 1.0:
            raise InvalidInputError(f"test_size as a fraction must be in (0, 1), got {test_size}")
        n_test = int(round(test_size * len(drives)))
    else:
        # A count of drives; out-of-range counts are clamped below, as documented.
        n_test = check_int(test_size, "test_size (a number of drives)")
    n_test = min(max(n_test, 1), len(drives) - 1)
    order = np.random.default_rng(seed).permutation(len(drives))
    test_drives = drives[order[:n_test]]
    is_test = np.isin(dataset.groups, test_drives)
    return Subset(dataset, np.flatnonzero(~is_test)), Subset(dataset, np.flatnonzero(is_test))


def subset(dataset: DepthDataset, fraction: float, seed: int = 0) -> Subset:
    """A random fraction of the frames (in their original order), e.g. the study's 25 %.

    Parameters
    ----------
    dataset : DepthDataset
    fraction : float
        In (0, 1]; at least one frame is kept.
    seed : int
        Non-negative integer seed of the draw.

    Raises
    ------
    TypeError
        If ``dataset`` is not a DepthDataset, ``fraction`` is not a number or ``seed``
        is not a non-negative integer.
    ValueError
        If ``fraction`` is outside (0, 1].
    """
    _require_dataset(dataset, "subset's dataset")
    seed = check_seed(seed, "seed")
    if not is_real_number(fraction):
        raise InvalidTypeError(f"fraction must be a number in (0, 1], got {fraction!r}")
    if not 0.0 < fraction <= 1.0:
        raise InvalidInputError(f"fraction must be in (0, 1], got {fraction}")
    n = len(dataset)
    k = max(1, int(round(fraction * n)))
    keep = np.sort(np.random.default_rng(seed).choice(n, size=k, replace=False))
    return Subset(dataset, keep)
