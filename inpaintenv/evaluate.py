"""Score any inpainting method on a fixed, seeded set of (frame, occlusion) pairs.

The path of one frame: ground truth ``gt`` and the measured input from a data source (the
map itself, or a single LiDAR scan: :mod:`inpaintenv.data.inputs`) -> occlusion ``hole``
from the protocol's mask for ``(seed, index)`` -> method input
:func:`~inpaintenv.data.inputs.method_input` (NaN = fill, 0 = no measurement) ->
reconstruction -> :func:`inpaintenv.metrics.frame_metrics`.

The benchmark knows nothing about any particular method: ``method`` is any callable
``depth_with_nan_holes -> depth`` or any object with ``predict`` (a scikit-learn style
estimator). This module never imports ``estimators`` or torch.

Example
-------
>>> import numpy as np
>>> from inpaintenv.evaluate import evaluate
>>> gt = np.full((2, 32, 48), 10.0, dtype=np.float32)
>>> res = evaluate(lambda x: np.nan_to_num(x, nan=10.0), gt, progress=False)
>>> float(res.table[0]["hole_rmse"])
0.0
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ._version import __version__
from .conventions import (
    DEFAULT_MAX_DEPTH,
    check_int,
    check_max_depth,
    check_seeds,
)
from .data.base import DepthDataset, as_dataset
from .data.inputs import method_input
from .masks import OcclusionProtocol, get_protocol
from .methods.calls import Predictor, method_name
from .methods.intervals import IntervalSource, interval_source
from .exceptions import BadFrameError, InvalidInputError, MethodOutputError, ResultRowError, UnfilledPixelsError
from .metrics import (CALIBRATION_LEVELS, Coverage, FrameBatch, as_coverage, check_unfilled, computed_metrics, interval_metrics,
                      metric_records, ScoredPixels)
from .report.results import METRIC_COLUMNS, EvaluationResult
from .values.rows import RowPlan, UniqueRows, check_row

__all__ = ["BAD_FRAME_ERRORS", "EvaluationPlan", "check_on_bad_frame", "evaluate", "evaluate_plan", "resolve_source",
           "training_drives_of"]


#: What loading an unreadable frame raises: a corrupt, truncated, 8-bit or vanished PNG
#: (``DepthFormatError``, ``OSError``) or a frame breaking the depth convention (``ValueError``).
BAD_FRAME_ERRORS: tuple[type[BaseException], ...] = (ValueError, OSError)
_SKIP_HINT = "skip unreadable frames with --on-bad-frame skip (on_bad_frame='skip' in Python)"


# ---------------------------------------------------------------------------------------
# Inputs: methods and sources
# ---------------------------------------------------------------------------------------
def resolve_source(source: Any = None) -> DepthDataset:
    """Turn ``source`` into a :class:`~inpaintenv.data.base.DepthDataset`.

    Parameters
    ----------
    source : DepthDataset, array-like, Gymnasium env of this package, or None
        ``None`` is the built-in default, ``inpaintenv.data.open_source()`` (64 frames
        of :class:`SyntheticStreets`);
        an ``(N, H, W)`` / ``(H, W)`` array or a list of frames is wrapped; a
        ``DepthInpaintEnv`` (possibly wrapped) contributes its dataset.
    """
    if source is None:
        from .data.sources import (
            open_source,  # lazy: generating data is not import work
        )

        return open_source()
    if isinstance(source, DepthDataset):
        return source
    env_dataset = getattr(getattr(source, "unwrapped", None), "dataset", None)
    if isinstance(env_dataset, DepthDataset):
        return env_dataset
    return as_dataset(source)


def _load_batch(
    dataset: DepthDataset, idx: list[int], on_bad_frame: str
) -> tuple[np.ndarray, np.ndarray, list[int], list[dict[str, Any]]]:
    """Inputs and ground truth of frames ``idx``: ``(inputs, gt, kept indices, skipped-frame records)``.

    For a map source ``inputs`` is ``gt``.
    """
    try:
        return (*dataset.load_pairs(idx), idx, [])
    except BAD_FRAME_ERRORS as exc:
        if on_bad_frame == "error":
            raise BadFrameError(f"{exc}; {_SKIP_HINT}") from exc
    # Skip mode: load frame by frame to keep every good frame of the batch.
    pairs, kept, skipped = [], [], []
    for i in idx:
        try:
            pairs.append(dataset.load_pairs([i]))
            kept.append(i)
        except BAD_FRAME_ERRORS as exc:
            skipped.append({"index": i, "frame_id": str(dataset.frame_ids[i]), "drive": str(dataset.groups[i]),
                            "reason": str(exc)})
    empty = np.empty((0, *dataset.frame_shape), np.float32)
    gt = np.concatenate([p[1] for p in pairs]) if pairs else empty
    inputs = gt if dataset.input.is_map else np.concatenate([p[0] for p in pairs]) if pairs else empty
    return inputs, gt, kept, skipped


# ---------------------------------------------------------------------------------------
# The loop
# ---------------------------------------------------------------------------------------
def evaluate(
    method: Any,
    source: Any = None,
    protocol: str | OcclusionProtocol = "rect-v1",
    seeds: int | Sequence[int] = (0,),
    n_frames: int | None = None,
    *,
    batch_size: int = 4,
    max_depth: float = DEFAULT_MAX_DEPTH,
    progress: bool = True,
    name: str | None = None,
    indices: Sequence[int] | None = None,
    on_batch: Callable[[list[dict[str, Any]]], None] | None = None,
    on_bad_frame: str = "error",
    client: Any = None,
    unfilled: str = "error",
    warmup: bool = False,
    intervals: float | None = None,
) -> EvaluationResult:
    """Score ``method`` on every (seed, frame) pair of ``source`` under ``protocol``.

    Parameters
    ----------
    method : callable or object with ``predict``
        Takes the corrupted depth (metres, NaN = fill, 0 = no measurement) and returns
        the reconstruction: finite, non-negative metres, same shape. Objects with
        ``predict`` (estimators) and callables with ``batched = True`` receive
        ``(N, H, W)`` batches of up to ``batch_size`` frames; other callables receive one
        ``(H, W)`` frame per call.
    source : DepthDataset, array-like, DepthInpaintEnv, or None
        Ground truth, and the measured input its ``input_kind`` says (the map itself, or
        a single LiDAR scan: :mod:`inpaintenv.data.inputs`). ``None`` is the built-in
        :class:`SyntheticStreets` default.
    protocol : str or OcclusionProtocol
        Occlusion protocol, e.g. ``"rect-v1"``.
    seeds : int or sequence of int
        Evaluation seeds, distinct non-negative integers; frame ``i`` under seed ``s``
        gets ``protocol.mask(shape, s, i)``, so every mask is reproducible from
        ``(protocol, seed, index)`` alone.
    n_frames : int, optional
        Evaluate only the first ``n_frames`` frames of the source (an integer >= 1).
    batch_size : int
        Frames loaded (and, for batched methods, predicted) at a time.
    max_depth : float
        Range of PSNR in metres (80 m by default); finite and positive.
    progress : bool
        Show a tqdm progress bar on stderr (only when stderr is a terminal).
    name : str, optional
        Method name in the rows; default from :func:`method_name`.
    indices : sequence of int, optional
        Score only these frame positions, distinct integers in ``0..n_frames-1`` (masks still come from each frame's position in
        the source, so a subset scores exactly as in a full run). Used by the resumable
        benchmark runner.
    on_batch : callable, optional
        Called with the rows of every scored batch as soon as they exist (e.g. to append
        them to a file, so a killed run loses at most one batch).
    on_bad_frame : {"error", "skip"}
        A frame that cannot be read (corrupt, truncated or 8-bit PNG) or breaks the depth
        convention stops the evaluation with :class:`BadFrameError` naming it ("error"),
        or is left out and recorded in ``meta["skipped_frames"]`` with the reason ("skip").
    client : dask.distributed.Client, optional
        Score on this Dask cluster (``pip install "inpaintenv[dask]"``): each batch of
        ``batch_size`` frames is one task, run for every seed by a worker that loads the
        frames itself, so ``method`` and ``source`` must pickle. ``on_batch`` and the
        progress bar follow the batches as they finish (in any order); the rows are the
        ones of a local run, all but ``ms``. See :mod:`inpaintenv.cluster`.
    unfilled : {"error", "interpolate", "zero"}
        A reconstruction left at 0 m at a hole pixel with ground truth (unfilled; with a
        scan, at any pixel with ground truth the input did not measure) stops
        the evaluation with :class:`MethodOutputError` counting them ("error", the
        default; a 0 where the input was given is scored as given); or every 0 is filled first by the KITTI devkit's background interpolation
        ("interpolate", :func:`inpaintenv.metrics.interpolate_background`); or is scored
        as 0 m ("zero", how the study scored its hole-only baselines). Recorded in
        ``meta["unfilled"]``.
    warmup : bool
        Call the method once, untimed, on the first corrupted frame before the timed
        calls (its output is discarded), so that one-time start-up (torch's first call,
        a lazily loaded model) is not counted as time per frame in ``ms``. Off by
        default, so that the method sees exactly the scored inputs; the benchmark runner
        warms every method up once. Local runs only: a cluster run records no ``ms``.
    intervals : float, optional
        Also score the method's per-pixel interval of this nominal coverage (in (0, 1),
        e.g. 0.9), when it gives one: ``predict_interval(X, coverage=intervals) -> (low,
        high)``, or ``predict(X, return_std=True) -> (pred, std)`` (see
        :mod:`inpaintenv.methods.intervals`). Its rows then gain the columns of
        :data:`inpaintenv.metrics.INTERVAL_COLUMNS` (coverage, width, the
        error-rejection curve and the border-distance baseline), on the task's pixels:
        the hole, or under ``densify-v1`` every pixel the input did not measure; a method
        without an interval gets the rows of a run without ``intervals``. Recorded in
        ``meta["interval_coverage"]`` (and ``meta["interval_methods"]``, the methods that gave one).

    Returns
    -------
    EvaluationResult
        Rows and ``meta`` record the source's ``input_kind``. With a scan, the method is
        given the scan with the hole cut out (NaN wherever it did not measure), and rows
        score the hole, the unmeasured ground-truth pixels and all of them.

    Raises
    ------
    MethodOutputError
        If the method returns a wrong shape, a non-float, masked or sparse array, NaN/inf
        or negative depth, or (``unfilled="error"``) 0 m at a hole pixel with ground truth (the
        message names the method); with ``intervals``, an interval that is not a
        ``(low, high)`` pair of the batch's shape, is NaN/inf or negative, inverted, or
        does not hold the prediction in the hole.
    BadFrameError
        With ``on_bad_frame="error"``, on a frame that cannot be read (the message names
        the file or frame).
    inpaintenv.cluster.WorkerDataError, inpaintenv.cluster.ClusterError
        With ``client``: a worker cannot read the data (the message names the worker and
        the file), or the cluster cannot finish the run (no worker, workers that keep
        dying, no batch finishing within ``inpaintenv.cluster.SHARD_TIMEOUT`` seconds).
    TypeError
        If ``seeds``, ``indices``, ``n_frames`` or ``batch_size`` is not made of
        integers (floats, bools and strings are refused, not coerced), or ``max_depth``
        is not a number.
    ValueError
        On an empty source; negative, repeated or out-of-range ``seeds``/``indices``;
        ``n_frames`` or ``batch_size`` below 1; a NaN/inf/non-positive ``max_depth``;
        ground truth that breaks the depth convention (the message names the frame).
    """
    Predictor.of(method)  # a method that cannot be called is refused before any frame is opened
    dataset = resolve_source(source)
    proto = get_protocol(protocol)
    # Integers only, never coerced: int("12") loops, 0.5 -> 0 and repeats would all
    # score silently wrong sets of (seed, frame) pairs.
    seed_list = check_seeds(seeds, "seeds")
    batch_size = check_int(batch_size, "batch_size", minimum=1)
    max_depth = check_max_depth(max_depth)
    total, frame_list = _frames_to_score(dataset, n_frames, indices)
    check_on_bad_frame(on_bad_frame)
    check_unfilled(unfilled)
    plan = EvaluationPlan(dataset, proto, seed_list, frame_list, total, batch_size=batch_size, max_depth=max_depth,
                          on_bad_frame=on_bad_frame, unfilled=unfilled, client=client,
                          intervals=None if intervals is None else as_coverage(intervals, "intervals"))
    return evaluate_plan(method, plan, name=name, progress=progress, on_batch=on_batch, warmup=warmup)


def check_on_bad_frame(value: object) -> str:
    """``value`` if it is ``"error"`` or ``"skip"`` (what an unreadable frame does), else a ValueError."""
    if value not in ("error", "skip"):
        raise InvalidInputError(f"on_bad_frame must be 'error' or 'skip', got {value!r}")
    return str(value)


@dataclass(frozen=True)
class EvaluationPlan:
    """What one evaluation scores, every value checked where it entered (by :func:`evaluate` or
    the benchmark's run); nothing here is checked again.

    Parameters
    ----------
    dataset : DepthDataset
        The source.
    protocol : OcclusionProtocol
        The hole protocol.
    seeds : list of int
        Distinct non-negative seeds.
    frames : list of int
        Distinct positions below ``total`` to score.
    total : int
        Frames in play (``len(dataset)`` at most): ``meta["n_frames"]``.
    batch_size, max_depth, on_bad_frame, unfilled, intervals, client
        As :func:`evaluate`'s, checked (``intervals`` a checked :class:`~inpaintenv.metrics.Coverage`).
    """

    dataset: DepthDataset
    protocol: OcclusionProtocol
    seeds: list[int]
    frames: list[int]
    total: int
    batch_size: int = 4
    max_depth: float = DEFAULT_MAX_DEPTH
    on_bad_frame: str = "error"
    unfilled: str = "error"
    intervals: Coverage | None = None
    client: Any = None


def evaluate_plan(
    method: Any, plan: EvaluationPlan, *, name: str | None = None, progress: bool = False,
    on_batch: Callable[[list[dict[str, Any]]], None] | None = None, warmup: bool = False,
    on_predictions: Callable[..., None] = lambda *_: None, on_warm: Callable[[], None] = lambda: None,
) -> EvaluationResult:
    """:func:`evaluate` of a checked :class:`EvaluationPlan` (the benchmark's runner, a worker's shard).

    Others are :func:`evaluate`'s; ``on_predictions(seed, frames, out)`` sees each local batch; ``on_warm()`` ends warm-up.
    """
    predictor = Predictor.of(method, name)
    label = predictor.name

    from tqdm.auto import tqdm  # lazy: only needed when looping

    bar = tqdm(
        total=len(plan.frames) * len(plan.seeds), desc=f"evaluate {label}", unit="frame",
        disable=None if progress else True, leave=False,
    )
    batches = [plan.frames[s : s + plan.batch_size] for s in range(0, len(plan.frames), plan.batch_size)]
    try:
        if plan.client is not None:
            rows, skipped = _score_on_cluster(plan, bar, on_batch, batches, method=method, name=label)
        else:
            source_of_interval = interval_source(method, plan.intervals, label)
            rows, skipped = _score_locally(predictor, plan, bar, on_batch, batches, warmup=bool(warmup),
                                           interval=source_of_interval, on_predictions=on_predictions, on_warm=on_warm)
    finally:
        bar.close()

    # Report rows seed-major (all frames of seed 0, then seed 1, ...).
    dataset, intervals = plan.dataset, plan.intervals
    order = {s: j for j, s in enumerate(plan.seeds)}
    rows.sort(key=lambda r: (order[r["seed"]], r["index"]))
    meta = {
        "methods": [label], "protocol": plan.protocol.name,
        "seeds": list(plan.seeds),
        "n_frames": plan.total,
        "source": repr(dataset),
        "input_kind": dataset.input_kind,
        "frame_shape": list(dataset.frame_shape),
        "max_depth": float(plan.max_depth),
        "unfilled": plan.unfilled,
        "inpaintenv_version": __version__,
    }
    if intervals is not None:
        meta["interval_coverage"] = float(intervals)
        meta["interval_methods"] = [label] if any("hole_coverage" in r for r in rows) else []
    drives = training_drives_of(method)
    if drives is not None:
        meta["training_drives"] = {label: drives}
    if skipped:
        meta["skipped_frames"] = skipped
    return EvaluationResult(rows=rows, meta=meta)


def _frames_to_score(dataset: DepthDataset, n_frames: int | None, indices: Sequence[int] | None) -> tuple[int, list[int]]:
    """``(total, frame positions)``: frames of the source in play, and the ones to score."""
    total = len(dataset)
    if total == 0:
        raise InvalidInputError("the data source has no frames")
    if n_frames is not None:
        total = min(total, check_int(n_frames, "n_frames", minimum=1))
    if indices is None:
        return total, list(range(total))
    return total, check_seeds(indices, "indices", upper=total)


def _score_locally(
    predictor: Predictor, plan: EvaluationPlan, bar: Any, on_batch: Callable[[list[dict[str, Any]]], None] | None,
    batches: list[list[int]], *, warmup: bool = False, interval: IntervalSource | None = None,
    on_predictions: Callable[..., None] = lambda *_: None, on_warm: Callable[[], None] = lambda: None,
) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """Rows and skipped frames of ``batches``, scored in this process.

    ``interval`` (from ``plan.intervals``, the coverage asked) adds the interval columns, scored on
    the protocol's task pixels (the hole, or under densify-v1 every pixel the input lacks).
    """
    dataset, protocol, seeds, name = plan.dataset, plan.protocol, plan.seeds, predictor.name
    if interval is not None:
        predictor = predictor.wrapped(interval.wrap)
    rows: list[dict[str, Any]] = []
    skipped: list[dict[str, Any]] = []
    shape = tuple(dataset.frame_shape)
    for idx in batches:
        # Load inputs and ground truth once per batch and reuse them for every seed.
        inputs, gt, idx, bad = _load_batch(dataset, idx, plan.on_bad_frame)
        skipped.extend(bad)
        bar.update(len(bad) * len(seeds))
        if not idx:
            continue
        for seed in seeds:
            hole = protocol.masks(shape, seed, idx)
            x = method_input(inputs, hole, dataset.input_kind)
            if warmup:
                predictor.warm_up(x[0])
                warmup = False
                on_warm()
            pred, ms = predictor.run(x)
            on_predictions(seed, idx, pred)
            try:
                # Frames, masks, output and options were checked where they entered.
                scored_pixels = ScoredPixels(gt, hole, inputs=None if inputs is gt else inputs, check_input=False)
                metrics = scored_pixels.metrics(pred, max_depth=plan.max_depth, unfilled=plan.unfilled,
                                                check_input=False)
            except UnfilledPixelsError as exc:
                raise MethodOutputError(f"method {name!r}: {exc}") from None
            # The task's pixels, as the headline's: densify-v1's are every pixel the input lacks.
            scored = np.isnan(x) if protocol.task == "unmeasured" else hole
            low = high = None
            if interval is not None:
                low, high = interval.bounds(x, pred, scored, levels=CALIBRATION_LEVELS)
                metrics.update(interval_metrics(pred, gt, scored, low, high))
            levels = interval.at_levels if interval is not None else None
            metrics.update(computed_metrics(FrameBatch(pred, gt, scored, x, low, high, levels)))
            batch_rows = _rows(name, protocol.name, seed, idx, dataset, hole.mean(axis=(1, 2)), metrics, ms)
            rows.extend(batch_rows)
            if on_batch is not None:
                on_batch(batch_rows)
            bar.update(len(idx))
    return rows, skipped


def _rows(
    name: str, protocol: str, seed: int, idx: list[int], dataset: DepthDataset, fractions: np.ndarray,
    metrics: dict[str, np.ndarray], ms: float,
) -> list[dict[str, Any]]:
    """One row per frame of a scored batch (the columns of ``ROW_COLUMNS``)."""
    batch_rows: list[dict[str, Any]] = []
    record_columns = [r.name for r in metric_records() if r.name not in METRIC_COLUMNS]  # intervals, computed
    for k, i in enumerate(idx):
        row: dict[str, Any] = {
            "method": name,
            "protocol": protocol,
            "input_kind": dataset.input_kind,
            "seed": seed,
            "index": i,
            "frame_id": str(dataset.frame_ids[i]),
            "drive": str(dataset.groups[i]),
            "hole_fraction": float(fractions[k]),
        }
        for c in METRIC_COLUMNS:
            v = metrics[c][k]
            row[c] = int(v) if c.endswith("_count") else float(v)
        for c in record_columns:
            if c in metrics:
                row[c] = float(metrics[c][k])
        row["ms"] = ms
        batch_rows.append(row)
    return batch_rows


def training_drives_of(method: Any) -> list[str] | None:
    """The drives ``method`` was trained on (its ``training_drives_``), or None when it does not say.

    Learned estimators of this project record them when fitted and in their saved files;
    tables and headlines mark the rows of a drive that was in a method's training data.
    """
    drives = getattr(method, "training_drives_", None)
    if drives is None or isinstance(drives, (str, bytes)):
        return None
    try:
        return sorted({str(d) for d in drives})
    except TypeError:
        return None


def _score_on_cluster(
    plan: EvaluationPlan, bar: Any, on_batch: Callable[[list[dict[str, Any]]], None] | None, batches: list[list[int]],
    *, method: Any, name: str,
) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """Rows and skipped frames of ``batches``, each scored by :func:`_score_shard` on a Dask worker."""
    from .cluster import map_shards  # lazy: Dask is an optional extra

    dataset = plan.dataset
    # Rows cross a process (and maybe a network) here: each is checked before anything keeps it.
    rows_plan = RowPlan(methods={name}, protocol=plan.protocol.name, input_kind=dataset.input_kind,
                        seeds=set(plan.seeds), frame_ids=[str(f) for f in dataset.frame_ids],
                        drives=[str(g) for g in dataset.groups])
    unique = UniqueRows(default_input=dataset.input_kind)
    n_received = [0]

    def received(part: EvaluationResult) -> None:
        for row in part.rows:
            n_received[0] += 1
            try:
                rows_plan.check(check_row(row, max_depth=plan.max_depth))
                unique.add(row, f"row {n_received[0]} sent back")
            except ResultRowError as exc:
                raise ResultRowError(f"a Dask worker sent back a row that is not one of this run: {exc}") from None
        bar.update(len(part.rows) + len(part.meta.get("skipped_frames", [])) * len(plan.seeds))
        if on_batch is not None and part.rows:
            on_batch(part.rows)

    # The plan crosses to the workers once, without the client (a worker scores its shard locally).
    shared = {"method": method, "plan": replace(plan, client=None), "name": name}
    parts = map_shards(plan.client, _score_shard, batches, shared=shared, on_result=received)
    rows = [row for part in parts for row in part.rows]
    return rows, [rec for part in parts for rec in part.meta.get("skipped_frames", [])]


def _score_shard(indices: list[int], *, method: Any, plan: EvaluationPlan, name: str) -> EvaluationResult:
    """One batch of a distributed :func:`evaluate`, run on a Dask worker (the plan checked by the caller)."""
    shard = replace(plan, frames=indices, total=len(plan.dataset), batch_size=len(indices))
    return evaluate_plan(method, shard, name=name)
