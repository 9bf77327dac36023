"""The run loop of ``fill``: read ahead, fill in batches, write behind, one line per bad file."""

from __future__ import annotations

import os
import sys
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from ..data.calibration import Calibration
from ..exceptions import InvalidInputError
from ..interval_metrics import check_coverage
from ..method_intervals import IntervalSource
from ..report.progress import FrameProgress
from .methods import fill_batch, interval_method, make_method, shipped_interval_name
from .plan import FillJob, FillReport, plan
from .read import Holes, Item, Reader, check_box, message
from .write import write_outputs

__all__ = ["fill"]


class _Run:
    """One run's state: the method, the reader, the report."""

    def __init__(self, reader: Reader, report: FillReport, log: Callable[[str], None], stop: bool) -> None:
        self.method: Any = None
        self.interval: IntervalSource | None = None
        self.name = ""
        self.reader, self.report, self.log, self.stop = reader, report, log, stop

    def set_method(self, method: Any, name: str, interval: IntervalSource | None = None) -> None:
        self.method, self.name, self.interval = method, name, interval

    def write(self, item: Item, arrays: tuple[np.ndarray, ...]) -> None:
        """Write every output of one filled input (in the writer thread)."""
        write_outputs(item, arrays, lambda: self.reader.calibration(item.job))

    def fail(self, item: Item, line: str) -> None:
        self.report.failed.append((item.job.source, line))
        self.log(line)

    def predict(self, batch: list[Item]) -> list[tuple[Item, tuple[np.ndarray, ...] | None]]:
        """Fill a batch of same-sized items: per item the filled map (then, with an interval, its low and
        high); a batch that fails is retried frame by frame to name the bad one."""
        try:
            # In place: the arrays are this run's own, and a batch retried frame by frame sets its fill
            # pixels to NaN again, so what a failed batch wrote there is never read.
            out = fill_batch(self.method, self.name, [i.depth for i in batch], [i.fill for i in batch],
                             copy=False, interval=self.interval)
            step = 1 if self.interval is None else 3
            return [(item, tuple(out[step * k:step * (k + 1)])) for k, item in enumerate(batch)]
        except Exception as exc:  # noqa: BLE001
            if os.environ.get("INPAINTENV_TRACEBACK"):
                raise
            if len(batch) > 1:
                return [pair for item in batch for pair in self.predict([item])]
            batch[0].error = message(batch[0].job, exc)
            return [(batch[0], None)]


def _batches(items: Iterator[Item], size: int) -> Iterator[list[Item]]:
    """Consecutive readable items of one shape, at most ``size`` each; an unreadable item alone."""
    batch: list[Item] = []
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


def _read_ahead(reader: Reader, jobs: list[FillJob], pool: ThreadPoolExecutor, depth: int) -> Iterator[Item]:
    """The prepared items in order, read ``depth`` ahead by ``pool`` (decoding overlaps prediction)."""
    pending: deque[Future] = deque()
    queue = iter(jobs)
    for job in queue:
        pending.append(pool.submit(reader.prepare, job))
        if len(pending) >= depth:
            break
    while pending:
        item = pending.popleft().result()
        for job in queue:
            pending.append(pool.submit(reader.prepare, job))
            break
        yield item


def _loop(run: _Run, todo: list[FillJob], batch_size: int, progress: bool) -> None:
    """Fill ``todo``: reading, predicting and writing overlap; results go to ``run.report``."""
    report = run.report
    writes: deque[tuple[Item, Future]] = deque()

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
                run.fail(item, message(item.job, exc))
            bar.update(1)
        return not (run.stop and report.failed)

    with FrameProgress(len(todo), "fill", enabled=progress) as bar, \
            ThreadPoolExecutor(1, thread_name_prefix="fill-read") as reader, \
            ThreadPoolExecutor(1, thread_name_prefix="fill-write") as writer:
        for batch in _batches(_read_ahead(run.reader, todo, reader, 2 * batch_size), batch_size):
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


def _check_options(on_error: str, batch_size: int, confidence: float | None, intervals: Any) -> float | None:
    """The options' errors before anything is read; the checked coverage."""
    if on_error not in ("continue", "stop"):
        raise InvalidInputError(f"on_error must be 'continue' or 'stop', got {on_error!r}")
    if batch_size < 1:
        raise InvalidInputError(f"batch_size must be >= 1, got {batch_size}")
    if confidence is not None:
        return check_coverage(confidence, "confidence")
    if intervals is not None:
        raise InvalidInputError("--intervals is the calibration of --confidence's interval: give --confidence too")
    return None


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
    size : (int, int), optional
        Image width and height, for calibrations that do not hold it.
    camera : int, optional
        The camera to project scans into.
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
    confidence = _check_options(on_error, batch_size, confidence, intervals)
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
    hole_spec = Holes(Path(holes) if holes is not None else None, tuple(check_box(b) for b in boxes), missing)
    reader = Reader(hole_spec, calibration, size, camera)
    if any(j.is_scan for j in todo):
        reader.load_calibration()  # first: a missing --size fails in a second, not after loading a model
    run = _Run(reader, report, log, on_error == "stop")
    if confidence is not None and checkpoint is None and intervals is None:
        method = shipped_interval_name(method)  # "pretrained" -> "pretrained-intervals": its calibration
    run.set_method(*make_method(method, checkpoint, n_jobs))
    if confidence is not None:
        run.set_method(*interval_method(run.method, run.name, intervals, confidence))
    _loop(run, todo, batch_size, progress)
    return report
