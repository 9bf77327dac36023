"""The run loop of ``fill``: read ahead, fill in batches, write behind, one line per bad file."""

from __future__ import annotations

import os
import sys
from collections import deque
from dataclasses import replace
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from ..exceptions import InvalidInputError
from ..methods.intervals import IntervalSource
from ..files.lock import run_lock
from ..files import remove_stale_temporaries
from ..progress import FrameProgress
from .ledger import Ledger, file_identity
from .methods import fill_batch, interval_method, resolve_method, router, shipped_interval_name
from .plan import FillJob, FillReport, plan
from .options import FillOptions
from .read import Holes, Item, Reader, message
from .write import write_outputs

__all__ = ["fill"]


class _Run:
    """One run's state: the method, the reader, the report."""

    def __init__(self, reader: Reader, report: FillReport, log: Callable[[str], None], stop: bool) -> None:
        self.method: Any = None
        self.interval: IntervalSource | None = None
        self.name = ""
        self.reader, self.report, self.log, self.stop = reader, report, log, stop
        self.ledger: Ledger | None = None
        self.records: dict[FillJob, dict[str, Any]] = {}

    def set_method(self, method: Any, name: str, interval: IntervalSource | None = None) -> None:
        self.method, self.name, self.interval = method, name, interval
        self.report.method = name

    def write(self, item: Item, arrays: tuple[np.ndarray, ...]) -> None:
        """Write every output of one filled input (in the writer thread), between its intent and its record
        in the ledger (a kill between them leaves the intent: a rerun redoes the input)."""
        assert self.ledger is not None
        record = self.records[item.job]
        self.ledger.intend(record)
        write_outputs(item, arrays, lambda: self.reader.calibration(item.job))
        self.ledger.record(record)

    def fail(self, item: Item, line: str) -> None:
        self.fail_job(item.job, line)

    def fail_job(self, job: FillJob, line: str) -> None:
        self.report.failed.append((job.source, line))
        self.log(line)

    def predict(self, batch: list[Item]) -> list[tuple[Item, tuple[np.ndarray, ...] | None]]:
        """Fill a batch of same-sized items: per item the filled map (then, with an interval, its low and
        high); a batch that fails is retried frame by frame to name the bad one."""
        routed = router(self.method)
        before = getattr(routed, "routed_to_", None)
        try:
            # In place: the arrays are this run's own, and a batch retried frame by frame sets its fill
            # pixels to NaN again, so what a failed batch wrote there is never read.
            out = fill_batch(self.method, self.name, [i.depth for i in batch], [i.fill for i in batch],
                             copy=False, interval=self.interval)
            if routed is not None:
                _note_routes(batch, routed, before)
            step = 1 if self.interval is None else 3
            return [(item, tuple(out[step * k:step * (k + 1)])) for k, item in enumerate(batch)]
        except Exception as exc:  # noqa: BLE001
            if os.environ.get("INPAINTENV_TRACEBACK"):
                raise
            if len(batch) > 1:
                return [pair for item in batch for pair in self.predict([item])]
            batch[0].error = message(batch[0].job, exc)
            return [(batch[0], None)]


#: How the route line names each route's frames.
_KIND_WORDS = {"sparse": "sparse scan", "points": "scattered-point scan"}


def _note_routes(batch: list[Item], routed: Any, before: Any) -> None:
    """Each item's ``(kind, method)`` from the router's ``routed_to_`` of the call that just filled ``batch``
    (``before``: its value until then; a batch with nothing to fill made no call)."""
    names = getattr(routed, "routed_to_", None)
    filled = [item for item in batch if item.fill is not None and item.fill.any()]
    if names is None or names is before or len(names) != len(filled):
        return
    kinds = getattr(routed, "routed_kinds_", None)
    if kinds is None or len(kinds) != len(names):
        kinds = ["scan" if name == routed.scan_name else "map" for name in names]
    for item, name, kind in zip(filled, names, kinds):
        item.route = (_KIND_WORDS.get(kind, kind), str(name))


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
                if item.note:
                    run.log(f"{item.job.source}: {item.note}")
                if item.route is not None:
                    report.routes[item.route] = report.routes.get(item.route, 0) + 1
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


def _recipe(method: Any, options: FillOptions) -> dict[str, Any]:
    """What makes the pixels of every output of a run, besides its input and holes (for the ledger)."""
    checkpoint, confidence, intervals, input = options.checkpoint, options.confidence, options.intervals, options.input
    if checkpoint is not None:
        made_by: Any = {"checkpoint": file_identity(checkpoint)}
    elif isinstance(method, str):
        from ..methods.registry import canonical_name

        made_by = canonical_name(method)
    else:
        from ..files.identity import method_identity

        made_by = method_identity(method)
    return {"method": made_by, "confidence": confidence,
            "intervals": file_identity(intervals) if intervals is not None else None,
            **({"input": input} if input not in (None, "auto") else {})}


def _todo(jobs: list[FillJob], run: _Run, recipe: dict[str, Any], overwrite: bool) -> list[FillJob]:
    """The jobs to run (their ledger records kept in ``run``); the others skipped (done) or failed (outputs
    there that are not theirs)."""
    assert run.ledger is not None
    todo, folders = [], {}
    for job in jobs:
        record = run.ledger.new_record(job, {**recipe, **run.reader.identity(job)})
        if not overwrite:
            why = run.ledger.conflict(job, record)
            if why is not None:
                run.fail_job(job, why)
                continue
            if run.ledger.done(job):
                run.report.skipped.append(job.source)
                continue
        todo.append(job)
        run.records[job] = record
        folders.update((o.parent, job.out) for o in job.all_outputs)
    for folder, out in folders.items():  # what a killed run of this --out left half written
        remove_stale_temporaries(folder, within=out)
    return todo


def _method(method: Any, options: FillOptions) -> tuple[Any, str, IntervalSource | None]:
    """The method of a run, its name and (with ``confidence``) its interval source."""
    checkpoint, confidence, intervals = options.checkpoint, options.confidence, options.intervals
    if confidence is not None and checkpoint is None and intervals is None:
        method = shipped_interval_name(method)  # "pretrained" -> "pretrained-intervals": its calibration
    built, name = resolve_method(method, checkpoint, options.n_jobs, options.input)
    if confidence is None:
        return built, name, None
    return interval_method(built, name, intervals, confidence)


def fill(
    inputs: str | os.PathLike | Sequence[str | os.PathLike], out: str | os.PathLike, *,
    method: Any = "pretrained", options: FillOptions | None = None, **keywords: Any,
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
    options : FillOptions, optional
        How to fill (:class:`~inpaintenv.filling.options.FillOptions`, checked when made;
        default: its defaults).
    **keywords
        Fields of :class:`~inpaintenv.filling.options.FillOptions`, as a shorthand
        (``fill(inputs, out, holes="masks/", missing=True)``); with ``options``, they replace
        its fields.

    Returns
    -------
    FillReport
    """
    if options is None:
        o = FillOptions(**keywords)
    else:
        o = replace(options, **keywords) if keywords else options
    log = o.log or (lambda line: print(line, file=sys.stderr, flush=True))
    inputs = [inputs] if isinstance(inputs, (str, os.PathLike)) else list(inputs)
    if o.holes is not None and not Path(o.holes).exists():
        raise FileNotFoundError(f"--holes {o.holes}: no such mask file or folder")
    if isinstance(o.calibration, (str, os.PathLike)) and not os.path.lexists(o.calibration):
        # A mistyped path: one line before any input is read, not one per scan.
        raise FileNotFoundError(f"--calib {o.calibration}: no such calibration file or folder (a KITTI raw day "
                                "folder, an odometry calib.txt or a KITTI-360 calibration folder)")
    jobs, missing_inputs, ignored = plan(inputs, out, format=o.format, points=o.points,
                                         protect=[o.holes] if o.holes is not None else [],
                                         confidence=o.confidence is not None, preview=o.preview)
    if o.points is not None and not any(j.is_scan for j in jobs):
        raise InvalidInputError("points (--points) applies to .bin LiDAR scans, and there are none among the inputs")
    report = FillReport(ignored=ignored)
    for path, why in missing_inputs:
        report.failed.append((path, why))
        log(why)
    hole_spec = Holes(Path(o.holes) if o.holes is not None else None, tuple(o.boxes), o.missing, o.fill_all)
    reader = Reader(hole_spec, o.calibration, o.size, o.camera)
    if any(j.is_scan for j in jobs):
        reader.load_calibration()  # first: a missing --size fails in a second, not after loading a model
    run = _Run(reader, report, log, o.on_error == "stop")
    if o.overwrite or not all(os.path.lexists(p) for j in jobs for p in j.all_outputs):
        # Likely work: the method's errors (a bad name, no interval) come before anything is written to --out.
        run.set_method(*_method(method, o))
    with run_lock(out, log):  # a second run into the same --out is refused in one line
        run.ledger = Ledger(out)
        todo = _todo(jobs, run, _recipe(method, o), o.overwrite)
        if not todo or (report.failed and run.stop):
            return report
        if run.method is None:  # the outputs were there a moment ago, no longer
            run.set_method(*_method(method, o))
        _loop(run, todo, o.batch_size, o.progress)
    return report
