"""Fill your own depth maps and LiDAR scans: files or folders in, filled files out, in one call.

:func:`fill` is ``inpaintenv fill`` in Python. Each input file (a KITTI 16-bit depth PNG,
an ``.npy`` / ``.npz`` float array of metres, or a ``.bin`` LiDAR scan with its
calibration) becomes an output at the same path relative to its input under ``out``;
the pixels to fill are NaN (arrays), a hole mask (``holes``), boxes (``boxes``) or every
pixel without a measurement (``missing``). Measured pixels come out bit-identical, filled
ones positive and finite. Outputs that exist are skipped (the run resumes), each written
atomically; a bad file is one line naming it, and the others are still written. With
``confidence`` each depth file gets its per-pixel interval beside it (``<name>_low`` and
``<name>_high``, in the same formats), from the method's ``predict_interval``.

>>> from inpaintenv.filling import fill
>>> report = fill(["my_depth/"], "filled/", holes="my_masks/", method="scanline")   # doctest: +SKIP
>>> report.summary()                                                              # doctest: +SKIP
'fill: 12 written, 0 skipped, 0 failed'
"""

# long module: the planning, the pixels to fill and the run loop of `fill` are read together (each part short)
from __future__ import annotations

import os
import sys
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np

from .data.calibration import Calibration, read_calibration
from .data.depth_files import DEPTH_SUFFIXES, MASK_SUFFIXES, read_depth_file, read_mask_file, write_depth_file
from .conventions import DEPTH_LIMIT
from .data.io import KITTI_DEPTH_SCALE
from .data.projection import depth_to_points, project_scan, read_scan, write_points_bin, write_points_ply
from .exceptions import InvalidInputError
from .interval_metrics import check_coverage
from .method_calls import MethodOutputError, method_name, run_method
from .method_intervals import IntervalSource
from .report.progress import FrameProgress, count

__all__ = ["FORMATS", "NO_HOLES", "POINT_FORMATS", "FillJob", "FillReport", "fill", "fill_depth", "plan"]

#: Values of ``format``: the depth files written per input.
FORMATS = {"png": (".png",), "npy": (".npy",), "both": (".png", ".npy")}
#: Values of ``points``: the point files written per scan.
POINT_FORMATS = {None: (), "bin": (".bin",), "ply": (".ply",), "both": (".bin", ".ply")}
SCAN_SUFFIX = ".bin"
#: Suffixes (before the format's) of the interval files written beside each depth file.
INTERVAL_SUFFIXES = ("_low", "_high")
#: The error of an input where nothing marks a pixel to fill.
NO_HOLES = ("nothing marks the pixels to fill: give --holes MASK (a mask file, or a folder of masks by relative "
            "path; nonzero = fill), --box x0,y0,x1,y1 or --missing (every pixel without a measurement), or mark "
            "them NaN in an .npy/.npz (in Python: holes=, boxes=, missing=)")


@dataclass(frozen=True)
class FillJob:
    """One input file and the files it becomes.

    Attributes
    ----------
    source : pathlib.Path
        The input file.
    rel : pathlib.Path
        Its path relative to the input it was found in (the file name for a file input).
    outputs : tuple of pathlib.Path
        The depth files, then (scans only) the point files.
    intervals : tuple of (pathlib.Path, pathlib.Path)
        With ``confidence``: per depth file, its ``_low`` and ``_high`` files.
    """

    source: Path
    rel: Path
    outputs: tuple[Path, ...]
    intervals: tuple[tuple[Path, Path], ...] = ()

    @property
    def all_outputs(self) -> tuple[Path, ...]:
        """Every file the job writes: depth, interval and point files."""
        return (*self.outputs, *(p for pair in self.intervals for p in pair))

    @property
    def is_scan(self) -> bool:
        return self.source.suffix.lower() == SCAN_SUFFIX


@dataclass
class FillReport:
    """What a :func:`fill` run did: inputs written, skipped (outputs existed) and failed (with why)."""

    written: list[Path] = field(default_factory=list)
    skipped: list[Path] = field(default_factory=list)
    failed: list[tuple[Path, str]] = field(default_factory=list)
    ignored: list[Path] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """True when no input failed."""
        return not self.failed

    def summary(self) -> str:
        """``fill: 12 written, 3 skipped (outputs exist; overwrite to redo), 1 failed``."""
        skipped = f"{len(self.skipped)} skipped" + (" (outputs exist; --overwrite to redo them)" if self.skipped else "")
        line = f"fill: {len(self.written)} written, {skipped}, {len(self.failed)} failed"
        if self.ignored:
            line += (f"; {count(len(self.ignored), 'file')} of other kinds left alone (e.g. {self.ignored[0]}); "
                     f"read are {', '.join((*DEPTH_SUFFIXES, SCAN_SUFFIX))}")
        return line


def _walk(folder: Path) -> Iterator[Path]:
    """Files under ``folder``, sorted, hidden ones (``.name``, e.g. temporary files) left out."""
    for root, dirs, files in os.walk(folder):
        dirs[:] = sorted(d for d in dirs if not d.startswith("."))
        for name in sorted(files):
            if not name.startswith("."):
                yield Path(root) / name


def _is_under(path: Path, folder: Path) -> bool:
    return path == folder or folder in path.parents


def _interval_pair(path: Path) -> tuple[Path, Path]:
    """The ``_low`` and ``_high`` files beside the depth file ``path``."""
    return tuple(path.with_name(path.stem + s + path.suffix) for s in INTERVAL_SUFFIXES)  # type: ignore[return-value]


def plan(inputs: Sequence[str | os.PathLike], out: str | os.PathLike, *, format: str = "png",
         points: str | None = None, protect: Sequence[str | os.PathLike] = (), confidence: bool = False) -> tuple[
             list[FillJob], list[tuple[Path, str]], list[Path]]:
    """The jobs of a run: ``(jobs, missing inputs with why, ignored files)``.

    ``protect``: further files or folders never written into, whose files are not inputs (the mask
    or folder of masks, when it lies inside an input folder). ``confidence``: each depth file
    has its interval files beside it.

    Raises
    ------
    InvalidInputError
        If an output would be an input or lie in an input (or ``protect``) folder, ``out``
        is a file, or two inputs would write the same output.
    """
    if format not in FORMATS:
        raise InvalidInputError(f"format must be one of {', '.join(FORMATS)}, got {format!r}")
    if points not in POINT_FORMATS:
        raise InvalidInputError(f"points must be None, 'bin', 'ply' or 'both', got {points!r}")
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InvalidInputError(f"--out {out} is a file; give a folder")
    out_abs = out.resolve()
    given_all = [Path(p) for p in inputs]
    masks = [Path(p).resolve() for p in protect]
    folders = [g.resolve() for g in given_all if g.is_dir()] + masks
    files = {g.resolve() for g in given_all if g.is_file()}
    jobs, missing, ignored, by_output = [], [], [], {}
    for given in given_all:
        if given.is_dir():
            if _is_under(out_abs, given.resolve()):
                raise InvalidInputError(f"--out {out} lies inside the input folder {given}; fill never writes into an "
                                 "input folder: give another --out")
            found = [(p, p.relative_to(given)) for p in _walk(given)
                     if not masks or not any(_is_under(p.resolve(), m) for m in masks)]
        elif given.is_file():
            found = [(given, Path(given.name))]
        else:
            missing.append((given, f"{given}: no such file or folder"))
            continue
        for path, rel in found:
            suffix = path.suffix.lower()
            if suffix not in (*DEPTH_SUFFIXES, SCAN_SUFFIX):
                if given.is_dir():
                    ignored.append(path)
                else:
                    missing.append((path, f"{path}: not a depth file or scan (read are "
                                          f"{', '.join((*DEPTH_SUFFIXES, SCAN_SUFFIX))})"))
                continue
            extra = POINT_FORMATS[points] if suffix == SCAN_SUFFIX else ()
            outputs = tuple(out / rel.with_suffix(s) for s in (*FORMATS[format], *extra))
            intervals = tuple(_interval_pair(out / rel.with_suffix(s)) for s in FORMATS[format]) if confidence else ()
            job = FillJob(path, rel, outputs, intervals)
            for o in job.all_outputs:
                if o.resolve() in files or any(_is_under(o.resolve(), f) for f in folders):
                    raise InvalidInputError(f"{path} would be filled into {o}, an input or inside an input folder; fill "
                                     "never writes there: give another --out")
                if o.resolve() in by_output:
                    raise InvalidInputError(f"{path} and {by_output[o.resolve()]} would both be written to {o}; "
                                     "fill them into separate --out folders")
                by_output[o.resolve()] = path
            jobs.append(job)
    return jobs, missing, ignored


@dataclass
class _Holes:
    """Which pixels of an input to fill: NaN, a mask (file, or folder by relative path), boxes, missing."""

    holes: Path | None = None
    boxes: tuple[tuple[int, int, int, int], ...] = ()
    missing: bool = False
    _shared: np.ndarray | None = None

    def given(self) -> bool:
        return self.holes is not None or bool(self.boxes) or self.missing

    def _mask_path(self, job: FillJob) -> Path:
        assert self.holes is not None
        found = [p for s in MASK_SUFFIXES if (p := self.holes / job.rel.with_suffix(s)).is_file()]
        if len(found) != 1:
            why = "no mask" if not found else f"{len(found)} masks ({', '.join(p.name for p in found)})"
            raise InvalidInputError(f"{job.source}: {why} for it in {self.holes} (looked for "
                             f"{', '.join(str(job.rel.with_suffix(s)) for s in MASK_SUFFIXES)})")
        return found[0]

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
                raise InvalidInputError(f"{job.source}: the mask {path} is {mask.shape[1]}x{mask.shape[0]}, the depth map "
                                 f"{depth.shape[1]}x{depth.shape[0]} (width x height)")
            fill |= mask
        height, width = depth.shape
        for x0, y0, x1, y1 in self.boxes:
            if x0 >= width or y0 >= height:
                raise InvalidInputError(f"{job.source}: --box {x0},{y0},{x1},{y1} lies outside its {width}x{height} image")
            fill[y0:y1, x0:x1] = True
        if self.missing:
            fill |= depth == 0
        if not self.given() and not fill.any():
            raise InvalidInputError(f"{job.source}: {NO_HOLES}")
        return fill


def fill_depth(method: Any, depth: np.ndarray, fill: np.ndarray | None = None) -> np.ndarray:
    """Fill one depth map in memory, as :func:`fill` fills each file.

    Parameters
    ----------
    method : str, estimator or callable
        A registry name, or anything :func:`inpaintenv.evaluate.evaluate` scores (``predict``
        of NaN = fill).
    depth : numpy.ndarray
        ``(H, W)`` float metres, 0 = no measurement, NaN = fill.
    fill : numpy.ndarray of bool, optional
        Further pixels to fill (a hole mask).

    Returns
    -------
    numpy.ndarray
        ``depth``'s dtype and shape: measured pixels outside the fill bit-identical, pixels
        without a measurement outside it still 0, filled pixels positive and finite.
    """
    depth = np.asarray(depth)
    mask = np.isnan(depth) if fill is None else np.asarray(fill, dtype=bool) | np.isnan(depth)
    return _fill_batch(*_make_method(method, None, None), [depth], [mask])[0]


def _fill_batch(method: Any, name: str, depths: list[np.ndarray], fills: list[np.ndarray], *,
                copy: bool = True, interval: IntervalSource | None = None) -> list[np.ndarray]:
    """Fill same-sized maps in one ``predict`` call (in place unless ``copy``); frames with nothing to fill
    come back as they are. With ``interval``, each filled map is followed by its ``low`` and ``high``
    (the list holds ``3 · len(depths)`` arrays, in the depth's dtype)."""
    todo = [k for k, f in enumerate(fills) if f.any()]
    out = [d.copy() for d in depths] if copy else list(depths)
    if not todo:
        return [a for d in out for a in (d, d, d)] if interval is not None else out
    x = np.stack([depths[k] for k in todo]).astype(np.float32, copy=False)
    hole = np.stack([fills[k] for k in todo])
    x[hole] = np.nan
    # An object with predict is called batched; the interval source may swap in predict(X, return_std=True).
    caller = SimpleNamespace(predict=interval.wrap(method.predict)) if interval is not None else method
    pred, _ = run_method(caller, x, name)
    bounds = interval.bounds(x, pred, hole) if interval is not None else None
    for k, p in zip(todo, pred):
        unfilled = np.count_nonzero(fills[k] & (p <= 0))
        if unfilled:
            raise MethodOutputError(
                f"method {name!r} left {unfilled} of the {np.count_nonzero(fills[k])} pixels to fill at 0 m "
                "(no measurement near them?); try another method, e.g. --method scanline")
        np.copyto(out[k], p, where=fills[k], casting="same_kind")
    if bounds is None:
        return out
    lows, highs = [d.copy() for d in out], [d.copy() for d in out]
    for j, k in enumerate(todo):  # measured pixels: low = high = the measurement; unmeasured, unfilled: 0
        np.copyto(lows[k], bounds[0][j], where=fills[k], casting="same_kind")
        np.copyto(highs[k], bounds[1][j], where=fills[k], casting="same_kind")
    return [a for triple in zip(out, lows, highs) for a in triple]


def _atomic(path: Path, write: Callable[[Path], None]) -> None:
    """``write`` a temporary file beside ``path`` (same suffix, hidden), then rename it over ``path``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}{path.suffix}")
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


@dataclass
class _Item:
    job: FillJob
    depth: np.ndarray | None = None
    fill: np.ndarray | None = None
    points: np.ndarray | None = None
    error: str | None = None


def _message(job: FillJob, exc: BaseException) -> str:
    """One line naming the file and the problem."""
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if str(job.source) in text else f"{job.source}: {text}"


class _Run:
    """One run's state: the method, the holes, the calibration, the report and the two I/O threads."""

    def __init__(self, holes: _Holes, calibration: Any, size: tuple[int, int] | None, camera: int | None,
                 report: FillReport, log: Callable[[str], None], stop: bool) -> None:
        self.method: Any = None
        self.interval: IntervalSource | None = None
        self.name, self.holes = "", holes
        self._calib_args: tuple[Any, Any, Any] = (calibration, size, camera)
        self._calib: Calibration | Exception | None = None
        self.report, self.log, self.stop = report, log, stop

    def set_method(self, method: Any, name: str) -> None:
        self.method, self.name = method, name

    def set_interval(self, method: Any, name: str, source: IntervalSource) -> None:
        self.method, self.name, self.interval = method, name, source

    def load_calibration(self) -> None:
        """Read the calibration once, before the scans; unreadable, it fails each scan (the others go on)."""
        source, size, camera = self._calib_args
        if source is None:
            self._calib = InvalidInputError("a LiDAR scan needs its calibration: give --calib PATH (a KITTI raw day "
                                     "folder, an odometry calib.txt with --size WxH, or a KITTI-360 calibration "
                                     "folder)")
            return
        try:
            self._calib = (source.with_size(size) if isinstance(source, Calibration)
                           else read_calibration(source, size, camera))
        except (OSError, ValueError) as exc:
            self._calib = exc
            return
        self._calib.image_size()  # an odometry calib.txt without --size: an error in the options, before any file

    def calibration(self, job: FillJob) -> Calibration:
        if isinstance(self._calib, Exception):
            raise type(self._calib)(f"{job.source}: {self._calib}")
        return self._calib

    def prepare(self, job: FillJob) -> _Item:
        """Read one input and its mask (in the reader thread); errors are kept in the item."""
        try:
            if job.is_scan:
                points = read_scan(job.source)
                depth = project_scan(points, self.calibration(job))
                return _Item(job, depth, self.holes.fill_mask(job, depth), points)
            depth = read_depth_file(job.source)
            return _Item(job, depth, self.holes.fill_mask(job, depth))
        except Exception as exc:  # noqa: BLE001 - any unreadable input is one line, the run goes on
            if os.environ.get("INPAINTENV_TRACEBACK"):
                raise
            return _Item(job, error=_message(job, exc))

    def write(self, item: _Item, arrays: tuple[np.ndarray, ...]) -> None:
        """Write every output of one filled input (``arrays``: the filled map, then with an interval its
        low and high), each atomically (in the writer thread)."""
        assert item.fill is not None
        filled = arrays[0]
        for pair in item.job.intervals:
            for path, bound in zip(pair, arrays[1:]):
                if path.suffix.lower() == ".png":  # the PNG range: the interval's top end is cut there
                    bound = np.minimum(bound, np.float32(DEPTH_LIMIT))
                _atomic(path, lambda tmp, data=bound: write_depth_file(tmp, data))
        for path in item.job.outputs:
            suffix = path.suffix.lower()
            if suffix in (".png", ".npy"):
                data = filled
                tiny = item.fill & (filled < 1 / KITTI_DEPTH_SCALE)
                if suffix == ".png" and tiny.any():  # below half a PNG step it would be stored as 0 = no data
                    data = np.where(tiny, np.float32(1 / KITTI_DEPTH_SCALE), filled)
                _atomic(path, lambda tmp, data=data: write_depth_file(tmp, data))
            else:
                new = depth_to_points(filled, self.calibration(item.job), mask=item.fill)
                pts = np.vstack([item.points, np.hstack([new, np.zeros((len(new), 1))]).astype(np.float32)])
                writer = write_points_bin if suffix == ".bin" else write_points_ply
                _atomic(path, lambda tmp, pts=pts, writer=writer: writer(tmp, pts))

    def fail(self, item: _Item, message: str) -> None:
        self.report.failed.append((item.job.source, message))
        self.log(message)

    def predict(self, batch: list[_Item]) -> list[tuple[_Item, tuple[np.ndarray, ...] | None]]:
        """Fill a batch of same-sized items: per item the filled map (then, with an interval, its low and
        high); a batch that fails is retried frame by frame to name the bad one."""
        try:
            # In place: the arrays are this run's own, and a batch retried frame by frame sets its fill
            # pixels to NaN again, so what a failed batch wrote there is never read.
            out = _fill_batch(self.method, self.name, [i.depth for i in batch], [i.fill for i in batch],
                              copy=False, interval=self.interval)
            step = 1 if self.interval is None else 3
            return [(item, tuple(out[step * k:step * (k + 1)])) for k, item in enumerate(batch)]
        except Exception as exc:  # noqa: BLE001
            if os.environ.get("INPAINTENV_TRACEBACK"):
                raise
            if len(batch) > 1:
                return [pair for item in batch for pair in self.predict([item])]
            batch[0].error = _message(batch[0].job, exc)
            return [(batch[0], None)]


def _batches(items: Iterator[_Item], size: int) -> Iterator[list[_Item]]:
    """Consecutive readable items of one shape, at most ``size`` each; an unreadable item alone."""
    batch: list[_Item] = []
    for item in items:
        if item.error is not None or (batch and item.depth.shape != batch[0].depth.shape):
            if batch:
                yield batch
            batch = []
            if item.error is not None:
                yield [item]
                continue
        batch.append(item)
        if len(batch) >= size:
            yield batch
            batch = []
    if batch:
        yield batch


def _read_ahead(run: _Run, jobs: list[FillJob], pool: ThreadPoolExecutor, depth: int) -> Iterator[_Item]:
    """The prepared items in order, read ``depth`` ahead by ``pool`` (decoding overlaps prediction)."""
    pending: deque[Future] = deque()
    queue = iter(jobs)
    for job in queue:
        pending.append(pool.submit(run.prepare, job))
        if len(pending) >= depth:
            break
    while pending:
        item = pending.popleft().result()
        for job in queue:
            pending.append(pool.submit(run.prepare, job))
            break
        yield item


def _make_method(method: Any, checkpoint: Any, n_jobs: int | None) -> tuple[Any, str]:
    """The method of a run and its name: a registry name, a checkpoint folder, or an estimator as given."""
    from .registry import canonical_name, make_method

    name = str(method) if isinstance(method, str) else method_name(method)
    if checkpoint is not None:
        method, name = make_method("checkpoint", path=checkpoint), str(checkpoint)
    elif isinstance(method, str):
        method = make_method(canonical_name(method))
    if n_jobs is not None:
        params = method.get_params() if hasattr(method, "get_params") else {}
        if "n_jobs" not in params:
            raise InvalidInputError(f"--jobs applies to methods that take n_jobs (the classical ones); "
                             f"{method_name(method)} does not")
        method.set_params(n_jobs=n_jobs)
    return method, name


def _shipped_interval_name(method: Any) -> Any:
    """``<name>-intervals`` for a registry name whose release ships an interval calibration; else ``method``."""
    from .registry import DEFAULT_RELEASE, available_aliases, available_methods, canonical_name, get_spec

    if isinstance(method, str) and not method.count(":"):
        canon = canonical_name(method)
        spec = get_spec(canon)
        names = [f"{canon}-intervals"]
        if spec.cls == "load_release":  # any name of a release: blend-pretrained-mixed is kitti-mixed-v1
            names.append(f"{spec.kwargs.get('name', DEFAULT_RELEASE)}-intervals")
        for name in names:
            if name in available_methods() or name in available_aliases():
                return name
    return method


def _interval_method(method: Any, name: str, intervals: str | os.PathLike | None,
                     coverage: float) -> tuple[Any, str, IntervalSource]:
    """The method of a ``confidence`` run, its name and its interval source: ``intervals`` (a saved
    calibration) wraps ``method``; a method with its own interval is used as it is."""
    from .method_intervals import interval_source
    from .registry import available_methods, make_method

    if intervals is not None:
        if not Path(intervals).is_file():
            raise FileNotFoundError(f"--intervals {intervals}: no such calibration file")
        method = make_method("intervals", path=intervals, estimator=method)
        name = f"{name}+intervals"
    source = interval_source(method, coverage, name)
    if source is None:
        shipped = [m[: -len("-intervals")] for m in available_methods() if m.endswith("-intervals")]
        ships = f", or a method shipped with one ({', '.join(shipped)})" if shipped else ""
        raise InvalidInputError(
            f"--confidence needs a per-pixel interval and method {name!r} has none: give --intervals CAL.json (a "
            f"ConformalIntervalInpainter calibration of this method, saved with .save){ships}")
    return method, name, source


def fill(
    inputs: str | os.PathLike | Sequence[str | os.PathLike], out: str | os.PathLike, *,
    method: Any = "pretrained", checkpoint: str | os.PathLike | None = None,
    holes: str | os.PathLike | None = None, boxes: Sequence[tuple[int, int, int, int]] = (), missing: bool = False,
    calibration: str | os.PathLike | Calibration | None = None, size: tuple[int, int] | None = None,
    camera: int | None = None, format: str = "png", points: str | None = None, overwrite: bool = False,
    on_error: str = "continue", n_jobs: int | None = None, batch_size: int = 4, progress: bool = True,
    log: Callable[[str], None] | None = None, confidence: float | None = None,
    intervals: str | os.PathLike | None = None,
) -> FillReport:
    """Fill depth files and LiDAR scans (files or folders, read recursively) into ``out``.

    Parameters
    ----------
    inputs : path-like or sequence of path-like
        Files and folders: KITTI 16-bit PNGs, ``.npy`` / ``.npz`` float metres (NaN = fill),
        ``.bin`` scans (with ``calibration``). Each output keeps its path relative to its input.
    out : path-like
        The output folder; never inside an input folder.
    method : str or estimator
        A registry name (default ``"pretrained"``) or an object with ``predict``.
    checkpoint : path-like, optional
        A saved model's folder, used instead of ``method``.
    holes : path-like, optional
        A mask for every input, or a folder of masks matched by relative path (nonzero = fill).
    boxes : sequence of (x0, y0, x1, y1)
        Rectangles to fill, columns ``x0..x1-1``, rows ``y0..y1-1``.
    missing : bool
        Fill every pixel without a measurement (densify).
    calibration : path-like or Calibration, optional
        For scans (see :func:`~inpaintenv.data.calibration.read_calibration`); ``size``
        and ``camera`` are passed to it.
    format : {"png", "npy", "both"}
        Depth files written per input.
    points : {None, "bin", "ply", "both"}
        For scans, also the original points plus the filled pixels back-projected (reflectance 0).
    overwrite : bool
        Redo inputs whose outputs exist (they are skipped otherwise).
    on_error : {"continue", "stop"}
        A bad input is reported and the run goes on, or stops there.
    n_jobs : int, optional
        Passed to methods that take it (the classical ones).
    batch_size : int
        Same-sized frames per ``predict`` call.
    progress : bool
        A progress bar on a terminal, progress lines otherwise.
    log : callable, optional
        Receives each error line (default: printed to stderr).
    confidence : float, optional
        Nominal coverage in (0, 1) of a per-pixel interval written beside each depth file,
        as ``<name>_low`` and ``<name>_high`` in the same formats (low = high = the
        measurement at measured pixels, 0 where nothing was measured or filled; in a PNG
        ``high`` is capped at 65535/256 m). From the method's ``predict_interval`` (or
        ``predict(X, return_std=True)``); ``"pretrained"`` uses its shipped calibration.
    intervals : path-like, optional
        With ``confidence``: a calibration saved by
        :meth:`estimators.intervals.ConformalIntervalInpainter.save` to wrap ``method`` in.

    Returns
    -------
    FillReport
    """
    if on_error not in ("continue", "stop"):
        raise InvalidInputError(f"on_error must be 'continue' or 'stop', got {on_error!r}")
    if batch_size < 1:
        raise InvalidInputError(f"batch_size must be >= 1, got {batch_size}")
    if confidence is not None:
        confidence = check_coverage(confidence, "confidence")
    elif intervals is not None:
        raise InvalidInputError("--intervals is the calibration of --confidence's interval: give --confidence too")
    log = log or (lambda line: print(line, file=sys.stderr, flush=True))
    inputs = [inputs] if isinstance(inputs, (str, os.PathLike)) else list(inputs)
    if holes is not None and not Path(holes).exists():
        raise FileNotFoundError(f"--holes {holes}: no such mask file or folder")
    protect = [holes] if holes is not None else []
    jobs, missing_inputs, ignored = plan(inputs, out, format=format, points=points, protect=protect,
                                         confidence=confidence is not None)
    if points is not None and not any(j.is_scan for j in jobs):
        raise InvalidInputError("points (--points) applies to .bin LiDAR scans, and there are none among the inputs")
    report = FillReport(ignored=ignored)
    for path, why in missing_inputs:
        report.failed.append((path, why))
        log(why)
    done = [not overwrite and all(o.exists() for o in j.all_outputs) for j in jobs]
    todo = [j for j, d in zip(jobs, done) if not d]
    report.skipped = [j.source for j, d in zip(jobs, done) if d]
    if not todo or (missing_inputs and on_error == "stop"):
        return report
    hole_spec = _Holes(Path(holes) if holes is not None else None, tuple(_check_box(b) for b in boxes), missing)
    run = _Run(hole_spec, calibration, size, camera, report, log, on_error == "stop")
    if any(j.is_scan for j in todo):
        run.load_calibration()  # first: a missing --size fails in a second, not after loading a model
    if confidence is not None and checkpoint is None and intervals is None:
        method = _shipped_interval_name(method)  # "pretrained" -> "pretrained-intervals": its calibration
    run.set_method(*_make_method(method, checkpoint, n_jobs))
    if confidence is not None:
        run.set_interval(*_interval_method(run.method, run.name, intervals, confidence))
    writes: deque[tuple[_Item, Future]] = deque()

    def settle(wait_for: int) -> bool:
        """Collect finished writes (all but ``wait_for``); False once a failure should stop the run."""
        while writes and (len(writes) > wait_for or writes[0][1].done()):
            item, future = writes.popleft()
            try:
                future.result()
                report.written.append(item.job.source)
            except Exception as exc:  # noqa: BLE001 - e.g. a full disk: one line, the next file may fit
                if os.environ.get("INPAINTENV_TRACEBACK"):
                    raise
                run.fail(item, _message(item.job, exc))
            bar.update(1)
        return not (run.stop and report.failed)

    with FrameProgress(len(todo), "fill", enabled=progress) as bar, \
            ThreadPoolExecutor(1, thread_name_prefix="fill-read") as reader, \
            ThreadPoolExecutor(1, thread_name_prefix="fill-write") as writer:
        for batch in _batches(_read_ahead(run, todo, reader, 2 * batch_size), batch_size):
            results = run.predict(batch) if batch[0].error is None else [(batch[0], None)]
            for item, filled in results:
                if filled is None:
                    run.fail(item, item.error or f"{item.job.source}: failed")
                    bar.update(1)
                else:
                    writes.append((item, writer.submit(run.write, item, filled)))
            if not settle(2 * batch_size) or (run.stop and report.failed):
                break
        settle(0)
    return report


def _check_box(box: Sequence[int]) -> tuple[int, int, int, int]:
    """``(x0, y0, x1, y1)`` as ints with ``0 <= x0 < x1`` and ``0 <= y0 < y1``; one clear error otherwise."""
    values = tuple(box)
    if len(values) != 4 or not all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) for v in values):
        raise InvalidInputError(f"a box is four pixel integers x0,y0,x1,y1, got {box!r}")
    x0, y0, x1, y1 = (int(v) for v in values)
    if not (0 <= x0 < x1 and 0 <= y0 < y1):
        raise InvalidInputError(f"a box x0,y0,x1,y1 needs 0 <= x0 < x1 and 0 <= y0 < y1 (columns x0..x1-1, rows "
                         f"y0..y1-1), got {x0},{y0},{x1},{y1}")
    return x0, y0, x1, y1
