"""What a per-frame result row may be, checked by every reader of rows.

A row is what :func:`inpaintenv.evaluate.evaluate` scores for one (method, protocol,
input, seed, frame): identity columns, the hole fraction, a column per metric record
(:func:`inpaintenv.metrics.metric_records`: the depth metrics, the interval columns of a
method that gives intervals, any registered metric), the pixel counts, and ``ms``.
Rows are read back from a benchmark's row files on resume, by ``inpaintenv report``, from
``results.json`` and ``results.csv``, and from Dask workers; each of those readers passes
what it read through :func:`check_row` (one row), :class:`RowPlan` (the row belongs to
this run) or :class:`SameFrames`, and :class:`UniqueRows` (one row per key), so a new
reader cannot trust a row as it is.

A row is refused (:class:`~inpaintenv.exceptions.ResultRowError`, naming the column) when:

* a column is neither an identity column, a count nor a metric record's, or a required one
  is missing (the unmeasured, KITTI and interval columns are each all there or all absent:
  older rows lack the first two);
* an identity column has the wrong type (a bool is not an integer) or an integer is negative
  (which input kinds a run has is its plan's to say);
* a metric is outside the range its record gives (:attr:`inpaintenv.metrics.Metric.bounds`),
  infinite, or NaN although the record's pixels (its ``count`` column) are there -- a
  ratio (a record without a unit) may also be NaN where its denominator is 0; a frame
  whose region holds no pixel (a count of 0) has NaN metrics there, and only then, and
  that frame is left out of the means as skipped;
* the columns disagree with each other: a PSNR that is not its RMSE's, KITTI's four that
  are not the all-pixel ones in their units, an MAE above its RMSE, a region holding more
  pixels than the frame, unmeasured columns that are not the hole's on a map input.

What a consistent row could have been cannot be checked without scoring its frame again:
a row rewritten with every column coherent passes.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from ..conventions import DEFAULT_MAX_DEPTH
from ..exceptions import ResultRowError, UnknownNameError
from ..metrics import (
    INTERVAL_COLUMNS, KITTI_METRICS, METRIC_NAMES, REGIONS, UNMEASURED_METRICS, Metric, metric_record, psnr_of,
)

__all__ = ["ROW_KEY", "RowPlan", "SameFrames", "UniqueRows", "check_row", "row_column_kind"]

#: The columns that say which score a row is: one row per key in a run.
ROW_KEY: tuple[str, ...] = ("method", "protocol", "input_kind", "seed", "index")

_TEXT = ("method", "protocol", "input_kind", "frame_id", "drive")
_COUNTS = ("hole_count", "all_count", "unmeasured_count")
_WHOLE = ("seed", "index", *_COUNTS)
_DEPTH = tuple(f"{r}_{m}" for r in REGIONS for m in METRIC_NAMES) + tuple(f"{r}_count" for r in REGIONS)
_UNMEASURED = tuple(f"unmeasured_{m}" for m in UNMEASURED_METRICS) + ("unmeasured_count",)
_KITTI = tuple(f"kitti_{m}" for m in KITTI_METRICS)
#: Columns every row has; the groups that are all there or all absent.
_REQUIRED = (*(c for c in _TEXT if c != "input_kind"), "seed", "index", "hole_fraction", *_DEPTH, "ms")
_GROUPS = {"unmeasured": _UNMEASURED, "KITTI": _KITTI, "interval": INTERVAL_COLUMNS}
#: Relative slack of the checks between columns (JSON and CSV give floats back exactly).
_SLACK = 1e-9


def row_column_kind(column: str) -> type | None:
    """What a row's ``column`` holds: ``str``, ``int`` (a whole number >= 0) or ``float``; None if no row has it.

    A float column is ``hole_fraction``, ``ms`` or a metric record's; registering a metric
    (:func:`inpaintenv.metrics.register_metric`) makes its column one a row may have.
    """
    if column in _TEXT:
        return str
    if column in _WHOLE:
        return int
    if column in ("hole_fraction", "ms"):
        return float
    try:
        metric_record(column)
    except UnknownNameError:
        return None
    return float


def check_row(raw: Mapping[str, Any], *, max_depth: float = DEFAULT_MAX_DEPTH, text: bool = False) -> dict[str, Any]:
    """``raw`` (a JSON object, or a CSV record with ``text=True``) as a typed row, if it is a possible one.

    Parameters
    ----------
    raw : mapping
        Column -> value as read: JSON numbers, strings and null (NaN), or CSV strings
        (an empty cell is NaN).
    max_depth : float
        The PSNR range the row was scored with (80 m unless the run said otherwise).
    text : bool
        Whether every value is a string (a CSV record).

    Returns
    -------
    dict
        The row with its types restored (``input_kind`` only when ``raw`` has it: a row
        without it is of the task's input).

    Raises
    ------
    ResultRowError
        Naming the column and what is wrong with it (see the module docstring).
    """
    if not isinstance(raw, Mapping):
        raise ResultRowError(f"a row is a JSON object, not {type(raw).__name__}")
    if text:
        raw = _present(raw)
    kinds = {k: row_column_kind(k) if isinstance(k, str) else None for k in raw}
    unknown = sorted(str(k) for k, kind in kinds.items() if kind is None)
    if unknown:
        raise ResultRowError(f"unknown column{'s' * (len(unknown) > 1)} {', '.join(map(_show, unknown[:5]))}")
    missing = [c for c in _REQUIRED if c not in raw]
    for group, columns in _GROUPS.items():
        present = [c for c in columns if c in raw]
        if present and len(present) < len(columns):
            missing += [c for c in columns if c not in raw]
    if missing:
        raise ResultRowError(f"missing column{'s' * (len(missing) > 1)} {', '.join(map(repr, missing[:5]))}")
    row = {column: _typed(column, value, kinds[column], text) for column, value in raw.items()}
    _check_values(row, max_depth)
    return row


def _present(record: Mapping[str, Any]) -> dict[str, Any]:
    """The columns a CSV record has: a CSV of rows with and without a metric (or a group of
    them) leaves its cells empty in the rows without it."""
    grouped = {c for columns in _GROUPS.values() for c in columns}
    # The unmeasured and KITTI columns are in every CSV that has them (empty where a frame has no truth).
    empty = set(INTERVAL_COLUMNS) if all(record.get(c) == "" for c in INTERVAL_COLUMNS) else set()
    return {k: v for k, v in record.items()
            if not (v == "" and (k in empty or (k not in grouped and k not in _REQUIRED and k != "input_kind")))}


def _typed(column: str, value: Any, kind: type | None, text: bool) -> Any:
    """``value`` of ``column`` in its ``kind``: a non-empty string, an integer >= 0 or a float (NaN for null)."""
    if kind is str:
        if not isinstance(value, str) or not value:
            raise ResultRowError(f"{column} must be a non-empty string, got {_show(value)}")
        return value
    if kind is int:
        if text and isinstance(value, str) and value.strip().isascii() and value.strip().isdecimal():
            return int(value)
        if type(value) is not int or value < 0:  # a bool is not a count
            raise ResultRowError(f"{column} must be a whole number >= 0, got {_show(value)}")
        return value
    if type(value) is float:
        return value
    if value is None or (text and value == ""):
        return math.nan
    if text and isinstance(value, str):
        try:
            return float(value)
        except ValueError:
            raise ResultRowError(f"{column} must be a number, got {_show(value)}") from None
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ResultRowError(f"{column} must be a number, got {_show(value)}")
    return float(value)


def _check_values(row: dict[str, Any], max_depth: float) -> None:
    """Every number of ``row`` in its record's range, NaN only where its pixels are none, the columns agreeing."""
    fraction = row["hole_fraction"]
    if not 0.0 <= fraction <= 1.0:
        raise ResultRowError(f"hole_fraction must be a share in [0, 1], got {_show(fraction)}")
    if not (math.isnan(row["ms"]) or 0.0 <= row["ms"] < math.inf):
        raise ResultRowError(f"ms must be a time >= 0 (or null), got {_show(row['ms'])}")
    # The task's pixels: the hole, or where no hole is cut (densify-v1) every unmeasured pixel.
    task = row["unmeasured_count"] if fraction == 0 and "unmeasured_count" in row else row["hole_count"]
    for column, value in row.items():
        if type(value) is float and column not in ("hole_fraction", "ms"):
            record = metric_record(column)
            _check_metric(column, value, record, task if record.count == "task" else row.get(record.count))
    _check_agreement(row, {r: row.get(f"{r}_count") for r in (*REGIONS, "unmeasured")}, max_depth)


def _check_metric(column: str, value: float, record: Metric, count: int | None) -> None:
    if value != value:  # NaN
        # A ratio (no unit) is NaN where its denominator is 0 although pixels were scored.
        if count and record.unit != "":
            raise ResultRowError(f"{column} is null (NaN) although its frame has {count} scored pixels")
        return
    if count == 0:
        raise ResultRowError(f"{column} is {_show(value)} although its frame has no scored pixel there (it must be null)")
    low, high = record.bounds
    slack = _SLACK * max(abs(low) if math.isfinite(low) else 0.0, abs(high) if math.isfinite(high) else 0.0, 1.0)
    if math.isinf(value) or not low - slack <= value <= high + slack:
        raise ResultRowError(f"{column} is {_show(value)}, outside what it can be ({low:g} to {high:g})")


def _show(value: Any) -> str:
    """``repr(value)``, cut short: a row's strings and numbers may be of any length, a message is one line."""
    text = repr(value)
    return text if len(text) <= 80 else f"{text[:60]}... ({len(text)} characters)"


def _close(a: float, b: float) -> bool:
    return abs(a - b) <= _SLACK * max(abs(a), abs(b), 1.0)


def _check_agreement(row: dict[str, Any], counts: dict[str, int | None], max_depth: float) -> None:
    """The columns of one frame agree: regions within the frame, MAE <= RMSE, PSNR and KITTI's from the RMSEs."""
    n_all = counts["all"]
    for region in ("hole", "unmeasured"):
        if counts[region] is not None and counts[region] > n_all:
            raise ResultRowError(f"{region}_count {counts[region]} exceeds all_count {n_all}")
    if counts["unmeasured"] is not None and counts["hole"] > counts["unmeasured"]:
        raise ResultRowError(f"hole_count {counts['hole']} exceeds unmeasured_count {counts['unmeasured']} "
                             "(every hole pixel is one the method was not given)")
    for region in (*REGIONS, "unmeasured"):
        rmse = row.get(f"{region}_rmse")
        if rmse is None or math.isnan(rmse):
            continue
        for small, large in (("mae", "rmse"), ("imae", "irmse")):
            if f"{region}_{large}" in row and row[f"{region}_{small}"] > row[f"{region}_{large}"] * (1 + _SLACK):
                raise ResultRowError(f"{region}_{small} {row[f'{region}_{small}']!r} exceeds {region}_{large} "
                                     f"{row[f'{region}_{large}']!r} (a mean error is at most its root mean square)")
        psnr = float(psnr_of(rmse, max_depth))
        if not _close(row[f"{region}_psnr"], psnr):
            raise ResultRowError(f"{region}_psnr {row[f'{region}_psnr']!r} is not the PSNR of {region}_rmse {_show(rmse)} "
                                 f"({_show(psnr)} dB for a range of {max_depth:g} m)")
    if row.get("input_kind") == "map" and counts["unmeasured"] is not None:
        # A map input is the truth itself: the pixels it did not give are the hole's.
        for column in _UNMEASURED:
            hole, other = row[column.replace("unmeasured", "hole")], row[column]
            if not (hole == other or (math.isnan(hole) and math.isnan(other)) or _close(hole, other)):
                raise ResultRowError(f"{column} {_show(other)} is not {column.replace('unmeasured', 'hole')} {_show(hole)} "
                                     "(on a map input the unmeasured pixels are the hole's)")
    if "kitti_rmse" in row and not math.isnan(row["all_rmse"]):
        for metric, scale in (("rmse", 1000.0), ("mae", 1000.0), ("irmse", 1.0), ("imae", 1.0)):
            if not _close(row[f"kitti_{metric}"], scale * row[f"all_{metric}"]):
                raise ResultRowError(f"kitti_{metric} {row[f'kitti_{metric}']!r} is not all_{metric} in KITTI's "
                                     f"units ({scale * row[f'all_{metric}']!r})")


@dataclass(frozen=True)
class RowPlan:
    """What rows a run planned for one row file: its methods, task, seeds and frames.

    Parameters
    ----------
    methods : collection of str
        The method names whose rows the file holds (names that share a file name).
    protocol, input_kind : str
        The task of the file.
    seeds : collection of int
        The run's seeds.
    frame_ids, drives : sequence of str
        Id and drive of each frame in play, by index (their length is the frames in play).
    """

    methods: Collection[str]
    protocol: str
    input_kind: str
    seeds: Collection[int]
    frame_ids: Sequence[str]
    drives: Sequence[str]

    def check(self, row: Mapping[str, Any]) -> None:
        """Refuse ``row`` (checked by :func:`check_row`) unless this run planned its score."""
        n = len(self.frame_ids)
        planned = (("method", row["method"] in self.methods, sorted(self.methods)),
                   ("protocol", row["protocol"] == self.protocol, self.protocol),
                   ("input_kind", row.get("input_kind", self.input_kind) == self.input_kind, self.input_kind),
                   ("seed", row["seed"] in self.seeds, sorted(self.seeds)),
                   ("index", row["index"] < n, f"0 to {n - 1}"))
        for column, ok, expected in planned:
            if not ok:
                raise ResultRowError(f"{column} {_show(row.get(column, self.input_kind))} is not one this run planned "
                                     f"({expected})")
        i = row["index"]
        for column, expected in (("frame_id", self.frame_ids[i]), ("drive", self.drives[i])):
            if row[column] != expected:
                raise ResultRowError(f"{column} {_show(row[column])} is not frame {i}'s ({_show(expected)})")


@dataclass
class UniqueRows:
    """Refuses a second row of one key (:data:`ROW_KEY`): which of two scores stands is not for a reader to guess."""

    default_input: str = "map"
    _seen: dict[tuple[Any, ...], str] = field(default_factory=dict)

    def add(self, row: Mapping[str, Any], where: str) -> None:
        """Record ``row`` (read at ``where``); ResultRowError if its key was seen before."""
        key = tuple(row.get(c, self.default_input) if c == "input_kind" else row[c] for c in ROW_KEY)
        first = self._seen.setdefault(key, where)
        if first != where:
            shown = ", ".join(f"{c} {_show(v)}" for c, v in zip(ROW_KEY, key))
            raise ResultRowError(f"a second row of {shown} (the first is {first})")


@dataclass
class SameFrames:
    """Refuses rows that describe one frame differently: its id, drive and pixels with ground
    truth are one for every row of it, its mask's share and pixels one for every row of one
    protocol and seed, whichever method scored it.

    What a reader without the run's data (a report rebuilt from a run folder, the rows a
    resume reads) can still check: a row copied in from a run on other data, or edited
    alone, disagrees with the rows of the other methods of the same frame.
    """

    _seen: dict[tuple[Any, ...], tuple[tuple[Any, ...], str]] = field(default_factory=dict)

    def add(self, row: Mapping[str, Any], where: str) -> None:
        """Record the frame ``row`` describes (read at ``where``); ResultRowError if another row described it otherwise."""
        kind = row.get("input_kind", "map")
        for key, columns, what in (
                ((kind, row["index"]), ("frame_id", "drive", "all_count"), "one frame has one id, drive and truth"),
                ((kind, row["index"], row["protocol"], row["seed"]), ("hole_fraction", "hole_count", "unmeasured_count"),
                 "one protocol and seed cut one mask from a frame")):
            values = tuple(row.get(c) for c in columns)
            seen, first = self._seen.setdefault(key, (values, where))
            for column, value, before in zip(columns, values, seen):
                if value != before and not (value != value and before != before):  # NaN is NaN
                    raise ResultRowError(f"{column} {_show(value)} of frame {row['index']} is not the {_show(before)} "
                                         f"of the row at {first} ({what})")

    def ids(self, input_kind: str, n_frames: int) -> list[str] | None:
        """The ids of frames ``0 .. n_frames - 1`` of ``input_kind``, or None when some frame has no row."""
        names = [self._seen.get((input_kind, i)) for i in range(n_frames)]
        return None if any(n is None for n in names) else [n[0][0] for n in names]
