"""Run a suite of methods over a data source and protocols, resumably.

A run scores tasks (:mod:`.tasks`): a protocol on the ground-truth map, or on single
LiDAR scans. Per-frame rows are appended to ``<out>/rows/<method>__<protocol>.jsonl``
(``..__scan.jsonl`` for a scan task) as soon as a batch is scored, so a killed run continues where it stopped: on restart, every
(seed, frame) already in the file is skipped. ``<out>/run.json`` fingerprints the run
(source, frames, protocols, seeds) and records what each method is (its identity, see
:mod:`.identity`); resuming into a folder of a different run, or reusing rows that another
model made under the same name, is an error.

A run holds the folder's lock (:mod:`.lock`) from start to end, so two runs never write
the same rows. Progress goes to tqdm bars on a terminal and, in a log, to a line every
:data:`PROGRESS_INTERVAL` seconds (:class:`~inpaintenv.progress.ProgressReporter`).
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from ..evaluate import check_on_bad_frame, evaluate_plan, resolve_source, training_drives_of
from ..files import remove_stale_temporaries
from ..masks import get_protocol
from ..metrics import as_coverage, check_unfilled
from ..progress import (
    ProgressReporter,
    count,
    format_duration,
    stderr_is_terminal,
)
from ..files.identity import method_identity
from .costs import relative_costs
from .kept_frames import KeptFrames
from ..files.lock import holds_lock, run_lock
from ..files.ownership import adopt, check_folder, claim, remove
from .rows import append_rows, end_partial_line, read_rows, rows_file_name
from .run_state import RunMismatchError, RunStateError, differences, read_run_file, run_fingerprint, write_run_file
from .suites import method_kind
from .run_plan import RunPlan, check_run
from .tasks import Task, task_datasets
from ..exceptions import InvalidInputError, UnsafeFileError
from ..report.results import EvaluationResult, merge_skipped
from ..values.rows import RowPlan, SameFrames

__all__ = ["RunMismatchError", "RunStateError", "run_benchmark"]


#: Seconds between progress lines when stderr is not a terminal (a log file).
PROGRESS_INTERVAL = 10.0

#: Errors meaning "this method cannot be built here" (missing package or weights).
UNAVAILABLE = (ImportError, KeyError, FileNotFoundError)


def _rows_file(name: str, task: Task) -> str:
    """The row file of ``name`` in ``task`` (:func:`.rows.rows_file_name`)."""
    return rows_file_name(name, task.protocol, task.input_kind)


def _check_identity(name: str, out: Path, recorded: str | None, identity: str, has_rows: bool) -> None:
    if has_rows and recorded is not None and recorded != identity:
        raise RunMismatchError(
            f"rows for {name!r} in {out} were made by {recorded}, not {identity}; "
            "pass --no-resume (resume=False) or another --out"
        )


def run_benchmark(
    methods: Mapping[str, Any],
    source: Any = None,
    *,
    protocols: str | Sequence[str] = ("rect-v1",),
    seeds: int | Sequence[int] = (0,),
    n_frames: int | None = None,
    out_dir: str | Path = "benchmark-results",
    resume: bool = True,
    batch_size: int = 4,
    progress: bool = True,
    log: Callable[[str], None] | None = None,
    on_bad_frame: str = "error",
    client: Any = None,
    unfilled: str | None = None,
    interval_coverage: float | None = None, kept: KeptFrames | None = None,
) -> EvaluationResult:
    """Score every method under every protocol and seed; return all per-frame rows.

    The run holds the lock of ``out_dir`` (:mod:`.lock`) throughout: a second run on the
    same folder fails at once instead of scoring everything twice.

    Parameters
    ----------
    methods : mapping of str to method
        Display name -> callable or estimator (see :func:`inpaintenv.evaluate.evaluate`).
        Values may also be zero-argument factories marked with ``lazy=True`` attribute
        (:class:`~inpaintenv.benchmark.LazyMethod`); they are built when some frame still
        needs scoring, or to confirm their identity on resume unless they carry one. A
        method with a ``scored_pairs`` attribute (a set of ``(seed, frame index)``, e.g. a
        submission missing some files) is scored on those pairs only.
    source : DepthDataset, array, mapping or None
        Ground truth to score on (None: the built-in SyntheticStreets default), whose
        ``input_kind`` says what a method is given; or ``{"map": dataset, "scan": dataset}``
        for a run with tasks on both inputs.
    protocols : str, Task or sequence of them
        The tasks, distinct (:mod:`.tasks`): a protocol name (a task on the source's input
        kind, or on maps with a mapping), ``"scan:<protocol>"``, or a
        :class:`~inpaintenv.benchmark.tasks.Task` (which may name the methods it scores).
    seeds : int or sequence of int
        Evaluation seeds: distinct non-negative integers (a single int means one seed).
    n_frames : int, optional
        Only the first ``n_frames`` frames (an integer >= 1).
    out_dir : path
        Folder for ``run.json`` and the per-method row files.
    resume : bool
        Keep rows already in ``out_dir`` and score only what is missing. With False every
        row file in the folder is deleted first and ``run.json`` is replaced.
    batch_size : int
        Frames per call of a method (>= 1).
    progress : bool
        Progress on stderr: tqdm bars on a terminal; otherwise (a log file) a line every
        10 s with frames done, rate and time left, sent to ``log``.
    log : callable, optional
        Receives the run's messages (plan, estimates, skipped methods).
    on_bad_frame : {"error", "skip"}
        What an unreadable ground-truth frame does (see :func:`inpaintenv.evaluate.evaluate`);
        skipped frames are listed in the result's ``meta["skipped_frames"]``.
    client : dask.distributed.Client, optional
        Score every (method, protocol, seed) on this Dask cluster, one task per batch
        (see :func:`inpaintenv.evaluate.evaluate`); rows land in ``out_dir`` as batches
        finish, so a distributed run resumes like a local one.
    unfilled : {"error", "interpolate", "zero"}, optional
        How every method's 0 m pixels where ground truth exists are scored (see
        :func:`inpaintenv.evaluate.evaluate`). None (default): each method's own
        ``unfilled`` attribute (:class:`~inpaintenv.benchmark.LazyMethod`, from the
        registry: ``"zero"`` for the study's hole-only baselines), else ``"error"``. A
        run-wide value is part of the run's fingerprint, so rows scored otherwise are
        never resumed into it. The policy of each method is in ``meta["unfilled"]``.
    interval_coverage : float, optional
        Also score the per-pixel interval of this nominal coverage (e.g. 0.9) of every
        method that gives one (``evaluate``'s ``intervals``): its rows gain coverage,
        width and the error-rejection columns; the others' rows are unchanged. Part of the
        run's fingerprint, so rows scored without it are never resumed into such a run.
    kept : KeptFrames, optional
        Keeps the predictions the figures draw as the run makes them (:mod:`.kept_frames`).

    Returns
    -------
    EvaluationResult
        Rows of every (method, protocol, seed, frame), methods in the given order;
        ``meta["kinds"]`` says what each method is (classical, learned or submitted, see
        :func:`~inpaintenv.benchmark.suites.method_kind`), as the headline labels it.

    Raises
    ------
    RunMismatchError
        On resume, if ``out_dir`` holds another run (data, frames, protocols, seeds), or
        rows of a method name that another model made (its recorded identity differs).
    RunStateError
        On resume, if ``out_dir/run.json`` is damaged.
    RunLockedError
        If another live process is running in ``out_dir``.
    ValueError, TypeError
        On no methods, no frames, or invalid ``protocols``, ``seeds``, ``n_frames`` or
        ``batch_size``.
    """
    single = None if isinstance(source, Mapping) else resolve_source(source)
    tasks, seeds = check_run(methods, protocols, seeds, n_frames, batch_size,
                             "map" if single is None else single.input_kind)
    datasets = task_datasets(source if single is None else single, tasks)
    check_on_bad_frame(on_bad_frame)
    policies = {
        name: check_unfilled(unfilled if unfilled is not None else getattr(m, "unfilled", "error"),
                             "unfilled" if unfilled is not None else f"the unfilled policy of {name!r}")
        for name, m in methods.items()
    }
    if interval_coverage is not None:
        interval_coverage = as_coverage(interval_coverage, "interval_coverage")
    if any(len(ds) == 0 for ds in datasets.values()):
        raise InvalidInputError("the data source has no frames")
    held = holds_lock(out_dir)  # a caller holding the lock (the command) checked the folder before taking it
    if not held:
        check_folder(out_dir)  # before the lock file is made in someone else's folder
    totals = {k: len(ds) if n_frames is None else min(len(ds), int(n_frames)) for k, ds in datasets.items()}
    plan = RunPlan(methods, datasets, tasks, seeds, totals, Path(out_dir), resume=resume,
                   say=log or (lambda msg: None), policies=policies, unfilled=unfilled, batch_size=batch_size,
                   progress=progress, on_bad_frame=on_bad_frame, client=client, intervals=interval_coverage,
                   kept=kept or KeptFrames({}, 0))
    with contextlib.nullcontext() if held else run_lock(out_dir, log):
        return _run_locked(plan)


def _plan_line(methods: Mapping[str, Any], total: int, tasks: list[Task], seeds: list[int], n_done: int,
               n_todo: int) -> str:
    what = count(len(tasks), "protocol") if all(t.input_kind == "map" for t in tasks) else \
        f"{count(len(tasks), 'task')} ({', '.join(t.label for t in tasks)})"
    return (f"benchmark: {count(total, 'frame')} × {count(len(methods), 'method')} × "
            f"{what} × {count(len(seeds), 'seed')} = "
            f"{count(n_done + n_todo, 'frame score')}; {n_done} already done, {n_todo} to score")


def _known_cost(rows_by_protocol: Mapping[str, list[dict[str, Any]]]) -> float | None:
    """Seconds per frame of a method from the ``ms`` of rows an earlier run wrote."""
    ms = [r["ms"] for rows in rows_by_protocol.values() for r in rows if math.isfinite(r.get("ms", math.nan))]
    return sum(ms) / len(ms) / 1000.0 if ms else None


def _run_locked(plan: RunPlan) -> EvaluationResult:
    """The run inside the folder's lock: open the run folder, plan, score each method, combine."""
    run = _Run(plan)
    run.open()
    run.schedule()
    results: list[EvaluationResult] = []
    for name, method in plan.methods.items():
        method = run.build(name, method)
        if method is not None:
            results.extend(run.score(name, method))
    if not results:
        raise InvalidInputError("no method could be run here (see the messages above)")
    return run.combine(results)


class _Run:
    """One benchmark run in its folder: what ``run.json`` records, the rows on disk, what
    is left to score, and the progress lines; one method per job (:func:`_run_locked`), all of
    one :class:`~.run_plan.RunPlan`."""

    def __init__(self, plan: RunPlan) -> None:
        self.plan = plan
        self.protocols = {t: get_protocol(t.protocol) for t in plan.tasks}  # names checked by check_tasks
        self.rows_dir = plan.out / "rows"
        self.run_file = plan.out / "run.json"
        # name -> identity of the method that wrote its rows (see .identity); a name missing
        # here (a run.json that records no identity for it) is unknown and accepted.
        self.identities: dict[str, str] = {}
        # name -> drives the method was trained on (see evaluate.training_drives_of), for the tables.
        self.trained: dict[str, list[str]] = {}
        self.skipped: list[list[dict[str, Any]]] = []
        self.reporter: ProgressReporter | None = None
        self._warmed: set[str] = set()  # methods warmed up (evaluate's ``warmup``) in this process
        self._frames: dict[str, tuple[list[str], list[str]]] = {}  # input kind -> ids and drives of its frames
        self._same = SameFrames()  # every row of one frame (and mask) describes it alike, across methods

    def save(self) -> None:
        write_run_file(self.run_file, self.fingerprint, self.identities, self.trained)

    def open(self) -> None:
        """Check the folder holds this run (on resume) or clear its rows; read what it recorded."""
        adopt(self.plan.out)
        if self.rows_dir.is_symlink():
            raise UnsafeFileError(f"{self.rows_dir} is a symbolic link; a run writes its rows in its own folder only")
        self.rows_dir.mkdir(parents=True, exist_ok=True)
        figures = self.plan.out / "figures"
        task_figures = [f for f in figures.iterdir() if f.is_dir() and not f.is_symlink()] \
            if figures.is_dir() and not figures.is_symlink() else []
        for folder in (self.plan.out, self.rows_dir, figures, *task_figures):
            remove_stale_temporaries(folder)  # left by a writer killed mid-write
        self.fingerprint = run_fingerprint(self.plan.datasets, self.plan.totals, self.plan.tasks, self.plan.seeds)
        resume, unfilled = self.plan.resume, self.plan.unfilled
        if unfilled is not None:
            # Only a run-wide choice: a method's own policy is part of what the method is, and
            # a run.json without the key (older runs, default runs) stays resumable.
            self.fingerprint["unfilled"] = unfilled
        if self.plan.intervals is not None:
            # Rows with interval columns and rows without must never be mixed in one run.
            self.fingerprint["interval_coverage"] = float(self.plan.intervals)
        if resume and self.run_file.exists():
            previous = read_run_file(self.run_file)
            recorded = previous.pop("methods", None)
            self.identities = {k: v for k, v in (recorded or {}).items() if isinstance(v, str)}
            self.trained = {k: [str(d) for d in v] for k, v in (previous.pop("training_drives", None) or {}).items()
                            if isinstance(v, list)}
            if "data" not in previous and "data" in self.fingerprint:
                # A run.json without the data's content: its content is unknown, so it is
                # accepted as it is (as a method without a recorded identity) and recorded now.
                previous["data"] = self.fingerprint["data"]
            changed = differences(previous, self.fingerprint)
            if changed:
                raise RunMismatchError(
                    f"{self.plan.out} holds results of a different run ({'; '.join(changed)}); "
                    "choose another --out or pass --no-resume to score again there"
                )
        if not resume:
            # Every row file goes, not only this run's methods': run.json is replaced, so
            # rows left behind could later be resumed under a fingerprint they do not match.
            # Only files a run recorded writing (the folder was checked to hold no others there).
            for stale in sorted(self.rows_dir.glob("*.jsonl")):
                remove(self.plan.out, stale.relative_to(self.plan.out))

    def schedule(self) -> None:
        """Rows already on disk, identities known without building anything (a changed method
        is refused before any scoring starts), what is left to score, the plan line."""
        methods, tasks, seeds, totals = self.plan.methods, self.plan.tasks, self.plan.seeds, self.plan.totals
        self.paths = {name: {t: self.rows_dir / _rows_file(name, t) for t in tasks} for name in methods}
        existing = {name: {t: self._read(name, t) for t in tasks} for name in methods}
        self.done = {
            name: {p: {(r["seed"], r["index"]) for r in rows} for p, rows in by_protocol.items()}
            for name, by_protocol in existing.items()
        }
        self.cheap: dict[str, str | None] = {
            name: getattr(m, "identity", None) if getattr(m, "lazy", False) else method_identity(m)
            for name, m in methods.items()
        }
        for name, identity in self.cheap.items():
            if identity is not None:
                _check_identity(name, self.plan.out, self.identities.get(name), identity,
                                any(self.done[name].values()))
        for name, m in methods.items():
            if not getattr(m, "lazy", False) and (drives := training_drives_of(m)) is not None:
                self.trained[name] = drives
        self.save()

        # A method with ``scored_pairs`` (a submission missing some files) scores only those (seed, frame) pairs.
        allowed = {name: getattr(m, "scored_pairs", None) for name, m in methods.items()}
        # A task that does not score a method (Task.methods) has nothing to do for it.
        self.todos = {
            name: {t: {s: [i for i in range(totals[t.input_kind] if t.scores(name) else 0)
                           if (s, i) not in self.done[name][t] and (allowed[name] is None or (s, i) in allowed[name])]
                       for s in seeds} for t in tasks}
            for name in methods
        }
        per_method = {name: sum(len(v) for t in self.todos[name].values() for v in t.values()) for name in methods}
        n_todo_all = sum(per_method.values())
        n_done_all = sum(len(d) for by_protocol in self.done.values() for d in by_protocol.values())
        self.plan.say(_plan_line(methods, max(totals.values()), tasks, seeds, n_done_all, n_todo_all))
        known = {name: c for name in methods if (c := _known_cost(existing[name])) is not None}
        if n_todo_all and all(name in known for name, k in per_method.items() if k):
            eta = sum(known[name] * k for name, k in per_method.items() if k)
            self.plan.say(f"estimate: {'' if eta < 0.5 else 'about '}{format_duration(eta)} (from the ms/frame of the "
                          "rows already scored)")
        # A terminal gets tqdm bars from evaluate(); a log gets periodic lines instead.
        if self.plan.progress and n_todo_all and not stderr_is_terminal():
            left = {name: {k: sum(len(v) for t, by_seed in self.todos[name].items() if t.input_kind == k
                                  for v in by_seed.values()) for k in totals} for name in methods}
            self.reporter = ProgressReporter(per_method, self.plan.say, seconds_per_frame=known,
                                             relative_cost=relative_costs(left), interval=PROGRESS_INTERVAL)

    def build(self, name: str, method: Any) -> Any:
        """``method`` ready to score (a lazy one built when needed), its identity checked and
        recorded; None when an optional method cannot be built here."""
        todo, done = self.todos[name], self.done[name]
        n_todo = {t: sum(len(v) for v in todo[t].values()) for t in self.plan.tasks}
        for t in self.plan.tasks:
            if n_todo[t]:
                self.plan.say(f"{name} / {t.label}: {count(n_todo[t], 'frame')} to score "
                              f"({len(done[t])} already done)")
        identity = self.cheap[name]
        recorded = self.identities.get(name)
        # A lazy method is built when frames need scoring, or when its rows carry an
        # identity that only the built method can confirm.
        if getattr(method, "lazy", False) and (any(n_todo.values()) or (identity is None and recorded is not None)):
            try:
                method = method()
            except UNAVAILABLE as exc:
                if not getattr(method, "optional", False):
                    raise
                self.plan.say(f"skipping {name!r}: not available here ({exc})")
                if self.reporter is not None:
                    self.reporter.drop(name)
                return None
            if identity is None:
                identity = method_identity(method)
                _check_identity(name, self.plan.out, recorded, identity, any(done.values()))
            drives = training_drives_of(method)
            if drives != self.trained.get(name):
                if drives is None:
                    self.trained.pop(name)
                else:
                    self.trained[name] = drives
                self.save()
        if identity is not None and identity != recorded:
            # Recorded before any row is written, so a killed run's rows are attributed.
            self.identities[name] = identity
            self.save()
        return method

    def score(self, name: str, method: Any) -> list[EvaluationResult]:
        """Score what is left of ``name`` in every task that scores it, appending rows to its files;
        return all its rows (old and new), one result per task."""
        if self.reporter is not None:
            self.reporter.begin(name)
        results = []
        for task in self.plan.tasks:
            if not task.scores(name):
                continue
            self._score_task(name, method, task, self.paths[name][task])
            # Every row is one the run planned, one per (seed, frame) (read_rows refuses others).
            rows = sorted(self._read(name, task), key=lambda r: (r["seed"], r["index"]))
            self.plan.kept.ranked(task.label, name, rows, f"{self.protocols[task].task}_rmse")
            results.append(EvaluationResult(rows=rows, meta={"methods": [name]}))
        return results

    def _read(self, name: str, task: Task) -> list[dict[str, Any]]:
        """The rows of ``name`` in ``task``'s file, each one this run planned (rows made before rows
        recorded their input are of its kind); a row the run did not plan is refused (RunStateError)."""
        file = _rows_file(name, task)
        if task.input_kind not in self._frames:
            dataset, total = self.plan.datasets[task.input_kind], self.plan.totals[task.input_kind]
            self._frames[task.input_kind] = ([str(f) for f in dataset.frame_ids[:total]],
                                             [str(g) for g in dataset.groups[:total]])
        frame_ids, drives = self._frames[task.input_kind]
        planned = RowPlan(methods={n for n in self.plan.methods if _rows_file(n, task) == file},
                          protocol=task.protocol, input_kind=task.input_kind, seeds=set(self.plan.seeds),
                          frame_ids=frame_ids, drives=drives)
        rows = [r for r in read_rows(self.rows_dir / file, planned, check=self._same.add) if r["method"] == name]
        for r in rows:
            r.setdefault("input_kind", task.input_kind)
        return rows

    def _score_task(self, name: str, method: Any, task: Task, path: Path) -> None:
        end_partial_line(path)
        # Claimed at the first scored batch: a run stopped by its first frame (a corrupt
        # PNG) must not leave an empty row file behind.
        claimed: list[bool] = []
        reporter = self.reporter

        def append(batch_rows: list[dict[str, Any]]) -> None:
            if not claimed:
                claim(self.plan.out, path.relative_to(self.plan.out))
                claimed.append(True)
            append_rows(path, batch_rows)
            if reporter is not None:
                reporter.update(len(batch_rows))

        for seed, indices in self.todos[name][task].items():
            if not indices:
                continue
            warmup = name not in self._warmed  # once per method, not per seed or protocol
            self._warmed.add(name)
            # Every argument was checked once, by run_benchmark: the frames are positions it planned.
            evaluation = self.plan.evaluation(name, task, self.protocols[task], seed, indices)
            part = evaluate_plan(method, evaluation, name=name, progress=self.plan.progress, on_batch=append,
                                 warmup=warmup, on_predictions=self.plan.kept.keeper(task.label, task.input_kind, name),
                                 on_warm=(lambda: None) if reporter is None else reporter.warmed)
            self.skipped.append(part.meta.get("skipped_frames") or [])

    def combine(self, results: list[EvaluationResult]) -> EvaluationResult:
        """Every method's rows in one result, with the run's meta and its skipped frames."""
        methods, trained = self.plan.methods, self.trained
        combined = EvaluationResult.concat(results)
        combined.meta.update(
            {"source": "; ".join(repr(ds) for ds in self.plan.datasets.values()),
             "protocols": list(dict.fromkeys(t.protocol for t in self.plan.tasks)), "seeds": self.plan.seeds,
             "n_frames": max(self.plan.totals.values()),
             "unfilled": {name: self.plan.policies[name] for name in combined.methods},
             "kinds": {name: method_kind(name, methods[name]) for name in combined.methods}}
        )
        if set(self.plan.datasets) != {"map"}:  # what each row is scored on: "scan:rect-v1" beside "rect-v1"
            combined.meta["tasks"] = [t.label for t in self.plan.tasks]
        if self.plan.intervals is not None:
            combined.meta["interval_coverage"] = float(self.plan.intervals)
            combined.meta["interval_methods"] = [
                m for m in combined.methods if any("hole_coverage" in r for r in combined.rows if r["method"] == m)]
        combined.meta.pop("training_drives", None)
        if any(name in trained for name in methods):
            combined.meta["training_drives"] = {name: trained[name] for name in methods if name in trained}
        combined.meta.pop("skipped_frames", None)
        merged = merge_skipped(self.skipped)
        if merged:
            combined.meta["skipped_frames"] = merged
            self.plan.say(f"skipped {len(merged)} unreadable frame{'s' * (len(merged) != 1)}: "
                     + "; ".join(f"{r['frame_id']} ({r['reason']})" for r in merged[:3])
                     + ("; ..." if len(merged) > 3 else ""))
        return combined
