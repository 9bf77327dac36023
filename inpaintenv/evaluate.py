"""Score any inpainting method on a fixed, seeded set of (frame, occlusion) pairs.

The path of one frame: ground truth ``gt`` from a data source -> occlusion ``hole`` from
the protocol's mask for ``(seed, index)`` -> method input ``corrupt(gt, hole)`` (NaN =
fill, 0 = no measurement) -> reconstruction -> :func:`inpaintenv.metrics.frame_metrics`.

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

import csv
import json
import math
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from . import tables
from ._version import __version__
from .conventions import DEFAULT_MAX_DEPTH, check_int, check_max_depth, check_seeds
from .data.base import DepthDataset, as_dataset
from .masks import OcclusionProtocol, get_protocol
from .metrics import METRIC_NAMES, REGIONS, aggregate, frame_metrics

__all__ = [
    "BAD_FRAME_ERRORS", "BadFrameError", "EvaluationResult", "MethodOutputError", "evaluate", "json_safe",
    "merge_skipped", "method_name", "parse_row", "resolve_source", "run_method", "skipped_markdown",
]

#: Per-frame metric columns, in report order.
METRIC_COLUMNS: tuple[str, ...] = tuple(
    f"{r}_{m}" for r in REGIONS for m in METRIC_NAMES
) + tuple(f"{r}_count" for r in REGIONS)
#: Identifying columns of a per-frame row, in report order.
ID_COLUMNS: tuple[str, ...] = ("method", "protocol", "seed", "index", "frame_id", "drive")
#: All per-frame columns, in report order.
ROW_COLUMNS: tuple[str, ...] = ID_COLUMNS + ("hole_fraction",) + METRIC_COLUMNS + ("ms",)
_INT_COLUMNS = ("seed", "index", "hole_count", "all_count")
_STR_COLUMNS = ("method", "protocol", "frame_id", "drive")


class MethodOutputError(ValueError):
    """A method returned an unusable reconstruction (wrong shape, NaN/inf, negative)."""


class BadFrameError(ValueError):
    """A ground-truth frame cannot be read or breaks the depth convention (the message names it)."""


#: What loading an unreadable frame raises: a corrupt, truncated, 8-bit or vanished PNG
#: (``DepthFormatError``, ``OSError``) or a frame breaking the depth convention (``ValueError``).
BAD_FRAME_ERRORS: tuple[type[BaseException], ...] = (ValueError, OSError)
_SKIP_HINT = "skip unreadable frames with --on-bad-frame skip (on_bad_frame='skip' in Python)"


# ---------------------------------------------------------------------------------------
# Inputs: methods and sources
# ---------------------------------------------------------------------------------------
def method_name(method: Any) -> str:
    """A readable name for ``method``: its ``name`` attribute, function name or class name."""
    name = getattr(method, "name", None)
    if isinstance(name, str) and name:
        return name
    if hasattr(method, "predict"):
        return type(method).__name__
    fn_name = getattr(method, "__name__", None)
    if isinstance(fn_name, str) and fn_name != "<lambda>":
        return fn_name
    return type(method).__name__ if fn_name is None else "lambda"


def _as_predictor(method: Any) -> tuple[Callable[[np.ndarray], Any], bool]:
    """Return ``(call, batched)``: ``batched`` means ``call`` takes ``(N, H, W)``.

    Objects with ``predict`` are batched (the estimator API). Plain callables get one
    ``(H, W)`` frame per call unless they set ``batched = True``.
    """
    predict = getattr(method, "predict", None)
    if callable(predict):
        return predict, True
    if callable(method):
        return method, bool(getattr(method, "batched", False))
    raise TypeError(
        f"method must be a callable depth -> depth or an object with predict(), got "
        f"{type(method).__name__}"
    )


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
        from .data.sources import open_source  # lazy: generating data is not import work

        return open_source()
    if isinstance(source, DepthDataset):
        return source
    env_dataset = getattr(getattr(source, "unwrapped", None), "dataset", None)
    if isinstance(env_dataset, DepthDataset):
        return env_dataset
    return as_dataset(source)


def _check_output(out: Any, expected: tuple[int, ...], name: str) -> np.ndarray:
    """Validate a method's reconstruction; errors name the method."""
    try:
        arr = np.asarray(out)
    except Exception as exc:  # e.g. a ragged list
        raise MethodOutputError(f"method {name!r} returned something that is not an array: {exc}") from exc
    if arr.dtype == object or arr.dtype == np.bool_ or not (
        np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)
    ):
        raise MethodOutputError(f"method {name!r} returned dtype {arr.dtype}; expected depth in metres")
    if arr.shape != expected:
        raise MethodOutputError(f"method {name!r} returned shape {arr.shape}, expected {expected}")
    arr = arr.astype(np.float32, copy=False)
    finite = np.isfinite(arr)
    if not finite.all():
        raise MethodOutputError(
            f"method {name!r} left {int((~finite).sum())} pixels NaN or inf; every pixel must be filled"
        )
    if (arr < 0).any():
        raise MethodOutputError(
            f"method {name!r} returned negative depth (min {float(arr.min()):.3g} m)"
        )
    return arr


# ---------------------------------------------------------------------------------------
# The result
# ---------------------------------------------------------------------------------------
def _mean(values: Iterable[float]) -> float:
    vals = [v for v in values if v is not None and not math.isnan(v)]
    return float(np.mean(vals)) if vals else float("nan")


@dataclass
class EvaluationResult:
    """Per-frame rows and the aggregate table of one or more evaluations.

    Attributes
    ----------
    rows : list of dict
        One row per (method, seed, frame): the columns of :data:`ROW_COLUMNS` --
        ``method``, ``protocol``, ``seed``, ``index`` (position in the source, which also
        seeds the mask), ``frame_id``, ``drive``, ``hole_fraction`` (occluded share of
        the frame), every metric of :func:`~inpaintenv.metrics.frame_metrics` (hole
        metrics are NaN when the hole holds no valid ground truth), and ``ms`` (wall
        clock of the method per frame; a batch's time is split evenly over its frames).
    meta : dict
        How the rows were produced (source, protocol, seeds, max_depth, version).
    """

    rows: list[dict[str, Any]]
    meta: dict[str, Any] = field(default_factory=dict)

    # -- aggregation -------------------------------------------------------------------
    def group_table(self, keys: Sequence[str] = ("method", "protocol")) -> list[dict[str, Any]]:
        """Aggregate the rows grouped by ``keys`` (mean over frames).

        Each output row holds the key values, :func:`inpaintenv.metrics.aggregate`'s
        result (``{region}_{metric}``, ``n_frames``, ``n_skipped_hole``), the mean
        ``hole_fraction`` and ``ms_per_frame``. Groups keep the order of first
        appearance.
        """
        groups: dict[tuple, list[dict[str, Any]]] = {}
        for row in self.rows:
            groups.setdefault(tuple(row[k] for k in keys), []).append(row)
        max_depth = float(self.meta.get("max_depth", DEFAULT_MAX_DEPTH))
        table = []
        for key, rows in groups.items():
            metrics = [{c: row[c] for c in METRIC_COLUMNS} for row in rows]
            agg = aggregate(metrics, how="mean", max_depth=max_depth)
            entry: dict[str, Any] = dict(zip(keys, key))
            entry.update(agg)
            entry["n_frames"] = int(agg["n_frames"])
            entry["hole_fraction"] = _mean(r["hole_fraction"] for r in rows)
            entry["ms_per_frame"] = _mean(r["ms"] for r in rows)
            table.append(entry)
        return table

    @property
    def table(self) -> list[dict[str, Any]]:
        """One aggregate row per (method, protocol): mean over all frames and seeds."""
        return self.group_table(("method", "protocol"))

    def by_drive(self) -> list[dict[str, Any]]:
        """One aggregate row per (method, protocol, drive)."""
        return self.group_table(("method", "protocol", "drive"))

    def by_seed(self) -> list[dict[str, Any]]:
        """One aggregate row per (method, protocol, seed)."""
        return self.group_table(("method", "protocol", "seed"))

    @property
    def methods(self) -> list[str]:
        """Method names in order of appearance."""
        return list(dict.fromkeys(r["method"] for r in self.rows))

    @classmethod
    def concat(cls, results: Sequence[EvaluationResult]) -> EvaluationResult:
        """Join several results (e.g. one per method) into one."""
        if not results:
            raise ValueError("no results to concatenate")
        rows = [row for r in results for row in r.rows]
        meta = dict(results[0].meta)
        meta["methods"] = list(dict.fromkeys(m for r in results for m in r.meta.get("methods", [])))
        protocols = list(dict.fromkeys(r.meta["protocol"] for r in results if "protocol" in r.meta))
        if len(protocols) > 1:
            meta["protocol"] = protocols
        seeds = list(dict.fromkeys(s for r in results for s in r.meta.get("seeds", [])))
        if seeds:
            meta["seeds"] = seeds
        skipped = merge_skipped(r.meta.get("skipped_frames") or [] for r in results)
        if skipped:
            meta["skipped_frames"] = skipped
        return cls(rows=rows, meta=meta)

    # -- output ------------------------------------------------------------------------
    def to_json(self, path: str | Path) -> Path:
        """Write ``{"meta", "skipped_frames", "table", "by_drive", "rows"}`` as JSON (NaN written as null).

        ``table`` and ``by_drive`` are :func:`inpaintenv.tables.summary_table` entries:
        means with interval bounds (null when undefined) and the frames in each mean.
        ``skipped_frames`` lists the unreadable frames left out (``on_bad_frame="skip"``)
        with the reason; it is empty when none were.
        """
        path = Path(path)
        doc = {
            "meta": {k: v for k, v in self.meta.items() if k != "skipped_frames"},
            "skipped_frames": self.meta.get("skipped_frames") or [],
            "table": tables.summary_table(self),
            "by_drive": tables.summary_table(self, ("method", "protocol", "drive")),
            "rows": self.rows,
        }
        path.write_text(json.dumps(json_safe(doc), indent=1))
        return path

    @classmethod
    def from_json(cls, path: str | Path) -> EvaluationResult:
        """Read a result written by :meth:`to_json`."""
        doc = json.loads(Path(path).read_text())
        rows = [parse_row(r) for r in doc["rows"]]
        meta = dict(doc.get("meta", {}))
        if doc.get("skipped_frames"):
            meta["skipped_frames"] = doc["skipped_frames"]
        return cls(rows=rows, meta=meta)

    def to_csv(self, path: str | Path) -> Path:
        """Write the per-frame rows as CSV (NaN written as an empty cell)."""
        path = Path(path)
        with path.open("w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=list(ROW_COLUMNS), extrasaction="ignore")
            writer.writeheader()
            for row in self.rows:
                writer.writerow({k: _csv_cell(row.get(k)) for k in ROW_COLUMNS})
        return path

    @classmethod
    def from_csv(cls, path: str | Path) -> EvaluationResult:
        """Read per-frame rows written by :meth:`to_csv` (``meta`` is empty)."""
        with Path(path).open(newline="") as f:
            rows = [parse_row(r) for r in csv.DictReader(f)]
        return cls(rows=rows, meta={})

    def to_markdown(
        self, table: list[dict[str, Any]] | None = None, *, keys: Sequence[str] | None = None
    ) -> str:
        """The table of these rows as Markdown, in the one format of every table.

        Means over frames with their 95 % bootstrap interval, units in the header,
        ``frames`` and ``skipped`` columns and the notes explaining them underneath (see
        :func:`inpaintenv.tables.to_markdown`).

        Parameters
        ----------
        table : list of dict, optional
            An aggregate table of these rows (e.g. :meth:`by_drive`); only its grouping
            is used: ``method``, ``protocol`` and whichever of ``drive``, ``seed`` it has.
        keys : sequence of str, optional
            Row columns to group by instead (default ``("method", "protocol")``).
        """
        if keys is None:
            extra = [k for k in ("drive", "seed") if table and k in table[0]]
            keys = ("method", "protocol", *extra)
        return tables.to_markdown(tables.summary_table(self, keys), keys)

    def __repr__(self) -> str:
        return f"EvaluationResult({len(self.rows)} rows, methods={self.methods})"


def merge_skipped(lists: Iterable[Sequence[dict[str, Any]]]) -> list[dict[str, Any]]:
    """Skipped-frame records of several results, one per frame, by frame index."""
    merged: dict[int, dict[str, Any]] = {}
    for records in lists:
        for rec in records:
            merged.setdefault(int(rec["index"]), dict(rec))
    return [merged[i] for i in sorted(merged)]


def skipped_markdown(skipped: Sequence[dict[str, Any]]) -> str:
    """The skipped frames as a Markdown list (empty string when none were skipped)."""
    if not skipped:
        return ""
    n = len(skipped)
    lines = [f"Unreadable frames left out: {n} (--on-bad-frame skip; not counted in frames or skipped):", ""]
    lines += [f"- frame {r['index']} ({r['frame_id']}): {r['reason']}" for r in skipped]
    return "\n".join(lines)


def _load_batch(
    dataset: DepthDataset, idx: list[int], on_bad_frame: str
) -> tuple[np.ndarray, list[int], list[dict[str, Any]]]:
    """Ground truth of frames ``idx``: ``(gt, kept indices, skipped-frame records)``."""
    try:
        return dataset.load_batch(idx), idx, []
    except BAD_FRAME_ERRORS as exc:
        if on_bad_frame == "error":
            raise BadFrameError(f"{exc}; {_SKIP_HINT}") from exc
    # Skip mode: load frame by frame to keep every good frame of the batch.
    frames, kept, skipped = [], [], []
    for i in idx:
        try:
            frames.append(dataset.load_batch([i])[0])
            kept.append(i)
        except BAD_FRAME_ERRORS as exc:
            skipped.append({"index": i, "frame_id": str(dataset.frame_ids[i]), "drive": str(dataset.groups[i]),
                            "reason": str(exc)})
    gt = np.stack(frames) if frames else np.empty((0, *dataset.frame_shape), np.float32)
    return gt, kept, skipped


def json_safe(obj: Any) -> Any:
    """``obj`` with every float NaN replaced by None (valid JSON), recursively."""
    if isinstance(obj, float) and math.isnan(obj):
        return None
    if isinstance(obj, dict):
        return {k: json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_safe(v) for v in obj]
    return obj


def _csv_cell(v: Any) -> Any:
    if isinstance(v, float) and math.isnan(v):
        return ""
    return v


def parse_row(raw: dict[str, Any]) -> dict[str, Any]:
    """Restore column types of a row read back from JSON or CSV."""
    row: dict[str, Any] = {}
    for k, v in raw.items():
        if k in _STR_COLUMNS:
            row[k] = str(v)
        elif v is None or v == "":
            row[k] = float("nan")
        elif k in _INT_COLUMNS:
            row[k] = int(v)
        else:
            row[k] = float(v)
    return row


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
        Ground truth. ``None`` is the built-in :class:`SyntheticStreets` default.
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

    Returns
    -------
    EvaluationResult

    Raises
    ------
    MethodOutputError
        If the method returns a wrong shape, NaN/inf or negative depth (the message names
        the method).
    BadFrameError
        With ``on_bad_frame="error"``, on a frame that cannot be read (the message names
        the file or frame).
    TypeError
        If ``seeds``, ``indices``, ``n_frames`` or ``batch_size`` is not made of
        integers (floats, bools and strings are refused, not coerced), or ``max_depth``
        is not a number.
    ValueError
        On an empty source; negative, repeated or out-of-range ``seeds``/``indices``;
        ``n_frames`` or ``batch_size`` below 1; a NaN/inf/non-positive ``max_depth``;
        ground truth that breaks the depth convention (the message names the frame).
    """
    call, batched = _as_predictor(method)
    label = name or method_name(method)
    dataset = resolve_source(source)
    proto = get_protocol(protocol)
    # Integers only, never coerced: int("12") loops, 0.5 -> 0 and repeats would all
    # score silently wrong sets of (seed, frame) pairs.
    seed_list = check_seeds(seeds, "seeds")
    batch_size = check_int(batch_size, "batch_size", minimum=1)
    max_depth = check_max_depth(max_depth)
    total = len(dataset)
    if total == 0:
        raise ValueError("the data source has no frames")
    if n_frames is not None:
        total = min(total, check_int(n_frames, "n_frames", minimum=1))
    if indices is None:
        frame_list = list(range(total))
    else:
        frame_list = check_seeds(indices, "indices", upper=total)
    shape = tuple(dataset.frame_shape)
    if on_bad_frame not in ("error", "skip"):
        raise ValueError(f"on_bad_frame must be 'error' or 'skip', got {on_bad_frame!r}")

    from tqdm.auto import tqdm  # lazy: only needed when looping

    rows: list[dict[str, Any]] = []
    skipped: list[dict[str, Any]] = []
    bar = tqdm(
        total=len(frame_list) * len(seed_list), desc=f"evaluate {label}", unit="frame",
        disable=None if progress else True, leave=False,
    )
    try:
        for start in range(0, len(frame_list), batch_size):
            idx = frame_list[start : start + batch_size]
            # Load ground truth once per batch and reuse it for every seed.
            gt, idx, bad = _load_batch(dataset, idx, on_bad_frame)
            skipped.extend(bad)
            bar.update(len(bad) * len(seed_list))
            if not idx:
                continue
            for seed in seed_list:
                hole = proto.masks(shape, seed, idx)
                x = gt.copy()
                x[hole] = np.nan
                pred, ms = _run(call, batched, x, label)
                metrics = frame_metrics(pred, gt, hole, max_depth=max_depth)
                fractions = hole.mean(axis=(1, 2))
                batch_rows: list[dict[str, Any]] = []
                for k, i in enumerate(idx):
                    row: dict[str, Any] = {
                        "method": label,
                        "protocol": proto.name,
                        "seed": seed,
                        "index": i,
                        "frame_id": str(dataset.frame_ids[i]),
                        "drive": str(dataset.groups[i]),
                        "hole_fraction": float(fractions[k]),
                    }
                    for c in METRIC_COLUMNS:
                        v = metrics[c][k]
                        row[c] = int(v) if c.endswith("_count") else float(v)
                    row["ms"] = ms
                    batch_rows.append(row)
                rows.extend(batch_rows)
                if on_batch is not None:
                    on_batch(batch_rows)
                bar.update(len(idx))
    finally:
        bar.close()

    # Report rows seed-major (all frames of seed 0, then seed 1, ...).
    order = {s: j for j, s in enumerate(seed_list)}
    rows.sort(key=lambda r: (order[r["seed"]], r["index"]))
    meta = {
        "methods": [label],
        "protocol": proto.name,
        "seeds": seed_list,
        "n_frames": total,
        "source": repr(dataset),
        "frame_shape": list(shape),
        "max_depth": float(max_depth),
        "inpaintenv_version": __version__,
    }
    if skipped:
        meta["skipped_frames"] = skipped
    return EvaluationResult(rows=rows, meta=meta)


def run_method(method: Any, x: np.ndarray, name: str | None = None) -> tuple[np.ndarray, float]:
    """Run ``method`` on a corrupted batch the way :func:`evaluate` does.

    Parameters
    ----------
    method : callable or object with ``predict``
    x : numpy.ndarray
        ``(N, H, W)`` float32 input, NaN = fill.
    name : str, optional
        Name used in error messages.

    Returns
    -------
    pred : numpy.ndarray
        Validated ``(N, H, W)`` float32 reconstruction.
    ms : float
        Wall clock of the method per frame, milliseconds.

    Raises
    ------
    ValueError
        If ``x`` is not ``(N, H, W)`` or holds no frames.
    MethodOutputError
        If the method's output is unusable.
    """
    x = np.asarray(x, dtype=np.float32)
    if x.ndim != 3:
        raise ValueError(f"run_method needs an (N, H, W) batch, got shape {x.shape}")
    if len(x) == 0:
        # Otherwise the per-frame time divides by zero.
        raise ValueError(f"run_method got no frames (shape {x.shape})")
    call, batched = _as_predictor(method)
    return _run(call, batched, x, name or method_name(method))


def _run(call: Callable, batched: bool, x: np.ndarray, label: str) -> tuple[np.ndarray, float]:
    """Run the method on a batch; return the validated prediction and ms per frame."""
    if batched:
        t0 = time.perf_counter()
        out = call(x)
        elapsed = time.perf_counter() - t0
        pred = _check_output(out, x.shape, label)
    else:
        pred = np.empty_like(x)
        elapsed = 0.0
        for k in range(len(x)):
            t0 = time.perf_counter()
            # Each frame gets its own copy so a method that writes into its input
            # cannot change what later frames or the metrics see.
            out = call(x[k].copy())
            elapsed += time.perf_counter() - t0
            pred[k] = _check_output(out, x.shape[1:], label)
    return pred, 1000.0 * elapsed / len(x)
