"""An optional on-disk cache of decoded frames for repeated passes over a dataset.

Decoding a KITTI PNG costs a few milliseconds per frame (see
``perf/profile_pipeline.py``); an epoch over 86k frames pays it every time. A
:class:`CachedDataset` stores every decoded (already cropped) frame once in a single
uint16 ``.npy`` file, memory-mapped, and serves later reads from it.

Encoding: ``uint16 = round(metres * 256)``, 0 = no measurement -- exactly KITTI's PNG
encoding, so for KITTI data the cache is lossless (same float32 values as the PNG
loader). Other sources (e.g. :class:`~inpaintenv.data.SyntheticStreets`) are rounded
to the nearest 1/256 m (error <= 1/512 m ~ 2 mm) and must stay below 256 m; the cached
dataset always returns the rounded values, whether a frame came from the cache or was
just decoded, so results never depend on what was cached before.

Layout of ``cache_dir``::

    meta.json      key, frame shape, frame ids, description of the source
    frames.npy     (N, H, W) uint16, memory-mapped
    filled.npy     (N,) uint8, 1 where the frame is in frames.npy

The key is a hash of the frame ids, the frame shape, the encoding and the source's
description (class, ``kind``, ``split``, ``camera``, ``crop``, ``seed`` when present --
not the root folder, so moving the data keeps the cache valid). A cache built for other
frames is *stale*: opening it raises :class:`StaleCacheError` unless
``on_stale="rebuild"``.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
from pathlib import Path
from typing import Any

import numpy as np

from ..files import open_regular, read_json, write_atomic, write_json
from .base import DepthDataset, Subset
from .io import KITTI_DEPTH_SCALE, depth_from_uint16
from ..exceptions import InvalidInputError, InvalidTypeError, OutOfRangeError, StaleCacheError

__all__ = ["CachedDataset", "StaleCacheError", "estimate_cache_bytes", "format_bytes"]

#: Bumped when the file layout or the encoding changes (old caches become stale).
CACHE_FORMAT_VERSION = 1
_ENCODING = "uint16 = round(metres * 256), 0 = no measurement"
_MAX_CODE = np.iinfo(np.uint16).max
#: Dataset attributes that change the pixels without changing the frame ids.
_DESCRIBING_ATTRS = ("kind", "split", "camera", "crop", "seed", "frames_per_drive")


def estimate_cache_bytes(dataset: DepthDataset) -> int:
    """Disk space a :class:`CachedDataset` of ``dataset`` needs, in bytes.

    Two bytes per pixel for the frames, one byte per frame for the fill flags, plus the
    ``.npy`` headers and ``meta.json`` (approximate: 100 bytes per frame id).
    """
    n = len(dataset)
    h, w = dataset.frame_shape
    return 2 * n * h * w + n + 2 * 128 + 512 + 100 * n


def format_bytes(n: float) -> str:
    """``1536 -> '1.5 KiB'``."""
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if abs(n) < 1024 or unit == "TiB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024
    raise AssertionError("unreachable")


def _describe(dataset: DepthDataset) -> dict[str, Any]:
    """What identifies the pixels of ``dataset`` besides its frame ids."""
    source = dataset.parent if isinstance(dataset, Subset) else dataset
    desc: dict[str, Any] = {"class": type(source).__name__}
    for attr in _DESCRIBING_ATTRS:
        value = getattr(source, attr, None)
        if isinstance(value, (str, int, float, bool)) or value is None:
            desc[attr] = value
        elif isinstance(value, (tuple, list)):
            desc[attr] = [v if isinstance(v, (str, int, float, bool)) else str(v) for v in value]
        else:
            desc[attr] = str(value)
    return desc


def _ids_digest(frame_ids: list[str]) -> str:
    return hashlib.sha256("\n".join(map(str, frame_ids)).encode()).hexdigest()


def encode_depth(depth: np.ndarray, name: str = "frame") -> np.ndarray:
    """float metres -> KITTI uint16 codes (rounded to 1/256 m).

    Raises
    ------
    ValueError
        On NaN, inf or negative depth, or depth of 256 m and more (not representable).
    """
    d = np.asarray(depth, dtype=np.float32)
    if not np.isfinite(d).all() or (d < 0).any():
        raise InvalidInputError(f"{name}: cached depth must be finite and non-negative")
    codes = np.rint(d * np.float32(KITTI_DEPTH_SCALE))
    if codes.size and codes.max() > _MAX_CODE:
        raise InvalidInputError(
            f"{name}: depth {float(d.max()):.2f} m exceeds 255.99 m, the range of the uint16 cache"
        )
    return codes.astype(np.uint16)


def _open_memmap(path: Path, mode: str) -> np.memmap:
    """The cache array ``path`` memory-mapped; a link, FIFO or device in the cache folder is refused unread."""
    os.close(open_regular(path, "cache file", follow_links=False))
    return np.lib.format.open_memmap(path, mode=mode)


class CachedDataset(DepthDataset):
    """A dataset whose decoded frames are kept in an on-disk uint16 memmap.

    Parameters
    ----------
    dataset : DepthDataset
        The source; its ``groups``, ``frame_ids`` and ``frame_shape`` are kept.
    cache_dir : path-like
        Folder of this cache (created if missing). One folder holds one dataset.
    on_stale : {"error", "rebuild"}
        What to do when ``cache_dir`` holds a cache of other frames: raise
        :class:`StaleCacheError` (default) or delete it and start empty.
    check_space : bool
        Raise ``OSError`` before creating the files if the disk has less free space than
        :func:`estimate_cache_bytes`.

    Notes
    -----
    Frames are cached lazily on first access, or all at once with :meth:`build`.
    Processes may share one cache folder (e.g. DataLoader or joblib workers): each
    opens the memmap itself, and two workers writing the same frame write the same
    bytes. Data reach the disk when the OS writes the pages back (:meth:`build` and
    :meth:`flush` force it); after a machine crash, check with :meth:`verify`.

    Examples
    --------
    >>> from inpaintenv.data import SyntheticStreets
    >>> ds = CachedDataset(SyntheticStreets(n=4), "/tmp/cache-demo")    # doctest: +SKIP
    >>> ds.build(progress=False)                                          # doctest: +SKIP
    """

    def __init__(
        self,
        dataset: DepthDataset,
        cache_dir: str | os.PathLike,
        *,
        on_stale: str = "error",
        check_space: bool = True,
    ):
        if not isinstance(dataset, DepthDataset):
            raise InvalidTypeError(f"dataset must be a DepthDataset, got {type(dataset).__name__}")
        if on_stale not in ("error", "rebuild"):
            raise InvalidInputError(f"on_stale must be 'error' or 'rebuild', got {on_stale!r}")
        if len(dataset) == 0:
            raise InvalidInputError("cannot cache an empty dataset")
        if not dataset.input.is_map:
            # Only the ground truth is cached: a scan source would silently become a map source.
            raise InvalidInputError(f"a CachedDataset caches ground-truth maps only, not a source of input kind {dataset.input_kind!r}")
        self.dataset = dataset
        self.cache_dir = Path(cache_dir)
        self.frame_shape = tuple(int(s) for s in dataset.frame_shape)  # type: ignore[assignment]
        self.groups = np.asarray(dataset.groups)
        self.frame_ids = list(dataset.frame_ids)
        self.meta = {
            "format_version": CACHE_FORMAT_VERSION,
            "encoding": _ENCODING,
            "n_frames": len(dataset),
            "frame_shape": list(self.frame_shape),
            "frame_ids_sha256": _ids_digest(self.frame_ids),
            "source": _describe(dataset),
        }
        self.key = hashlib.sha256(json.dumps(self.meta, sort_keys=True).encode()).hexdigest()
        self._frames: np.memmap | None = None
        self._filled: np.memmap | None = None
        self._open(on_stale, check_space)

    # -- files -------------------------------------------------------------------
    @property
    def _paths(self) -> tuple[Path, Path, Path]:
        d = self.cache_dir
        return d / "meta.json", d / "frames.npy", d / "filled.npy"

    def _open(self, on_stale: str, check_space: bool) -> None:
        meta_path, frames_path, filled_path = self._paths
        if meta_path.is_file():
            problem = self._stale_reason(meta_path)
            if problem is None:
                return
            if on_stale == "error":
                raise StaleCacheError(
                    f"cache {self.cache_dir} was built for other frames ({problem}); delete the "
                    "folder, use another cache_dir, or pass on_stale='rebuild'"
                )
            for p in self._paths:
                p.unlink(missing_ok=True)
        # A folder without meta.json is new or an interrupted creation: start afresh.
        self.cache_dir.mkdir(parents=True, exist_ok=True)
        need = estimate_cache_bytes(self)
        if check_space:
            free = shutil.disk_usage(self.cache_dir).free
            if free < need:
                raise OSError(
                    f"the cache needs {format_bytes(need)} but {self.cache_dir} has only "
                    f"{format_bytes(free)} free"
                )
        # open_memmap extends the file without writing zeros (sparse on Linux): cheap. Each
        # file is made under a temporary name and renamed, never written through a link.
        for path, dtype, shape in ((frames_path, np.uint16, self.shape), (filled_path, np.uint8, (len(self),))):
            write_atomic(path, lambda tmp, d=dtype, s=shape: np.lib.format.open_memmap(tmp, "w+", d, s).flush(),
                         "cache file")
        # meta.json last: its presence means the arrays exist.
        write_json(meta_path, dict(self.meta, key=self.key, frame_ids=self.frame_ids))

    def _stale_reason(self, meta_path: Path) -> str | None:
        """None if the cache on disk matches this dataset, else what differs."""
        try:
            old = read_json(meta_path, "cache meta.json", follow_links=False)
        except (OSError, ValueError) as exc:
            return f"unreadable meta.json: {exc}"
        if not isinstance(old, dict):
            return "meta.json is not a JSON object"
        if old.get("key") == self.key:
            _, frames_path, filled_path = self._paths
            for path, shape in ((frames_path, self.shape), (filled_path, (len(self),))):
                try:
                    arr = _open_memmap(path, "r")
                except (OSError, ValueError) as exc:
                    return f"{path.name} is missing or corrupt: {exc}"
                if arr.shape != tuple(shape):
                    return f"{path.name} has shape {arr.shape}, expected {tuple(shape)}"
            return None
        diffs = [
            f"{name} {old.get(k)!r} != {self.meta[k]!r}"
            for k, name in (
                ("format_version", "format version"),
                ("frame_shape", "frame shape"),
                ("n_frames", "number of frames"),
                ("source", "source"),
            )
            if old.get(k) != self.meta[k]
        ]
        if old.get("frame_ids_sha256") != self.meta["frame_ids_sha256"]:
            diffs.append("different frame ids")
        return "; ".join(diffs) or "different key"

    def _arrays(self) -> tuple[np.memmap, np.memmap]:
        # Opened lazily per process, so the dataset pickles without open file handles.
        if self._frames is None or self._filled is None:
            _, frames_path, filled_path = self._paths
            mode = "r+" if os.access(frames_path, os.W_OK) else "r"
            self._frames = _open_memmap(frames_path, mode)
            self._filled = _open_memmap(filled_path, mode)
        return self._frames, self._filled

    def __getstate__(self) -> dict[str, Any]:
        state = dict(self.__dict__)
        state["_frames"] = state["_filled"] = None
        return state

    # -- loading -----------------------------------------------------------------
    def _load(self, index: int) -> np.ndarray:
        frames, filled = self._arrays()
        if not filled[index]:
            self._fill(index)
        return depth_from_uint16(frames[index])

    def _fill(self, index: int) -> None:
        frames, filled = self._arrays()
        if not frames.flags.writeable:
            raise PermissionError(f"frame {index} is not cached and {self.cache_dir} is read-only")
        depth = self.dataset[index]
        if depth.shape != self.frame_shape:
            raise InvalidInputError(
                f"source frame {index} has shape {depth.shape}, expected {self.frame_shape}"
            )
        frames[index] = encode_depth(depth, name=f"frame {self.frame_ids[index]}")
        filled[index] = 1  # after the pixels, so a flag never points at missing data

    def load_batch(self, indices: Any) -> np.ndarray:
        """Load several frames as one ``(N, H, W)`` float32 array (one read when cached)."""
        idx = np.asarray(list(indices), dtype=np.int64).reshape(-1)
        if idx.size and (idx.min() < -len(self) or idx.max() >= len(self)):
            raise OutOfRangeError(f"frame indices out of range for a dataset of {len(self)} frames")
        idx %= len(self)
        frames, filled = self._arrays()
        for i in idx[filled[idx] == 0]:
            self._fill(int(i))
        return depth_from_uint16(frames[idx])

    # -- whole-cache operations ----------------------------------------------------
    @property
    def n_cached(self) -> int:
        """Number of frames already in the cache."""
        return int(np.count_nonzero(self._arrays()[1]))

    def build(self, progress: bool = True) -> CachedDataset:
        """Decode every frame not yet cached, then flush to disk.

        Prints the cache size (:func:`estimate_cache_bytes`) before starting.

        Parameters
        ----------
        progress : bool
            Print the size estimate and show a tqdm bar (on a terminal).

        Returns
        -------
        self
        """
        _, filled = self._arrays()
        todo = np.flatnonzero(filled == 0)
        if progress:
            print(
                f"cache {self.cache_dir}: {len(self)} frames of {self.frame_shape[1]}x"
                f"{self.frame_shape[0]} -> {format_bytes(estimate_cache_bytes(self))} on disk; "
                f"{len(todo)} to decode"
            )
        from tqdm.auto import tqdm  # lazy: only needed when building

        for i in tqdm(todo, desc="caching frames", unit="frame", disable=None if progress else True):
            self._fill(int(i))
        self.flush()
        return self

    def flush(self) -> None:
        """Write cached pages back to disk."""
        frames, filled = self._arrays()
        if frames.flags.writeable:
            frames.flush()
            filled.flush()

    def verify(self, indices: Any = None) -> list[int]:
        """Indices of cached frames that differ from the source (re-decodes them).

        Parameters
        ----------
        indices : sequence of int, optional
            Frames to check (default: all cached frames).
        """
        frames, filled = self._arrays()
        idx = np.flatnonzero(filled) if indices is None else np.asarray(list(indices), dtype=np.int64)
        bad = []
        for i in idx:
            if filled[i] and not np.array_equal(frames[i], encode_depth(self.dataset[int(i)])):
                bad.append(int(i))
        return bad

    def __repr__(self) -> str:
        return (
            f"CachedDataset({self.dataset!r}, cache_dir={str(self.cache_dir)!r}, "
            f"{self.n_cached}/{len(self)} cached)"
        )
