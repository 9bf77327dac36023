"""One record per metric: what a per-frame column is, how it pools, how it is shown.

Every per-frame metric column of a result row is a :class:`Metric`: its name (the row's
column), how a frame reduces it, how frames pool it, whether greater is better, its unit,
its label and format in a table, and the values it may take. :func:`aggregate
<inpaintenv.metrics.aggregate>` pools by it, :func:`inpaintenv.evaluate.evaluate` writes the
columns it names (and computes those whose record says how), the report's tables show
those of their group, and ``score`` (which scores through ``evaluate``) gives them too.
Adding a metric is one :func:`register_metric` (or one entry below) and its test.

Pooling (``pool``), over the frames that enter a mean (:attr:`Metric.frames`):

``"rms"``
    Square root of the pixel-weighted mean of the squared per-frame values (RMSE, iRMSE).
``"mean"``
    Pixel-weighted mean (MAE, coverage, width: means over pixels).
``"psnr"``
    Recomputed from the pooled RMSE of the same region (``<region>_rmse``).
``"frames"``
    Mean over frames, pooled or not: a per-image figure (a ratio, an area under a curve)
    has no pixel-pooled form from per-frame values; its pooled form, where it has one, is
    a record of its own (computed on every pixel of a run at once).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..conventions import DEPTH_LIMIT
from ..exceptions import InvalidInputError, UnknownNameError
from ._intervals import KEEP_GRID

__all__ = ["GROUPS", "POOLS", "FrameBatch", "Metric", "computed_metrics", "metric_record", "metric_records",
           "register_metric"]

#: How frames pool a metric (see the module docstring).
POOLS = ("rms", "mean", "psnr", "frames")
#: Which table shows a metric: every table (``"depth"``), tables of single-scan inputs (``"scan"``),
#: tables of rows with per-pixel intervals (``"interval"``); ``None``: rows only.
GROUPS = ("depth", "scan", "interval", None)
#: Which frames enter a metric's mean: those whose task pixels hold truth (``"task"``), those of
#: the all-pixel means (``"all"``: the task's, or every one with truth on request), or every frame
#: with ground truth (``"every"``, as the KITTI devkit averages).
FRAMES = ("task", "all", "every")


@dataclass(frozen=True)
class Metric:
    """One per-frame metric column.

    Parameters
    ----------
    name : str
        The row's column, e.g. ``"hole_rmse"``.
    reduce : str
        How a frame reduces it, in one sentence.
    pool : {"rms", "mean", "psnr", "frames"}
        How frames pool it (the module docstring).
    greater_is_better : bool
        True for a score, False for an error.
    unit : str
        ``"m"``, ``"mm"``, ``"1/km"``, ``"dB"``, ``"share"``, ``""`` (a ratio), ...
    label : str
        Table header, unit included.
    fmt : str
        Format of a table cell, e.g. ``".2f"``.
    low, high : float
        The values it may take, both included (``-inf``/``inf`` for none); NaN where its
        pixels are none.
    count : str
        The row column of its pixels per frame: the weight of ``"rms"``/``"mean"`` pooling
        (``"task"``: the task's count, ``hole_count`` or, under densify-v1, ``unmeasured_count``).
    frames : {"task", "all", "every"}
        Which frames enter its mean.
    group : {"depth", "scan", "interval"} or None
        Which table shows it.
    compute : callable, optional
        ``compute(batch) -> (N,) array`` for a metric ``evaluate`` computes from this
        record alone (``batch``: a :class:`~inpaintenv.metrics.FrameBatch`); None for the
        columns computed by :func:`~inpaintenv.metrics.frame_metrics` and
        :func:`~inpaintenv.metrics.interval_metrics`.
    needs_interval : bool
        ``compute`` reads the interval: computed only for a method that gives one.
    rank : int
        Its place among its table's columns (then the order of registration).
    """

    name: str
    reduce: str
    pool: str
    greater_is_better: bool
    unit: str
    label: str
    fmt: str
    low: float = 0.0
    high: float = math.inf
    count: str = "task"
    frames: str = "task"
    group: str | None = None
    compute: Callable[[Any], Any] | None = None
    needs_interval: bool = False
    rank: int = 100

    def __post_init__(self) -> None:
        if self.pool not in POOLS:
            raise InvalidInputError(f"metric {self.name!r}: pool must be one of {POOLS}, got {self.pool!r}")
        if self.group not in GROUPS:
            raise InvalidInputError(f"metric {self.name!r}: group must be one of {GROUPS}, got {self.group!r}")
        if self.frames not in FRAMES:
            raise InvalidInputError(f"metric {self.name!r}: frames must be one of {FRAMES}, got {self.frames!r}")
        if not self.low <= self.high:
            raise InvalidInputError(f"metric {self.name!r}: low {self.low} above high {self.high}")

    @property
    def bounds(self) -> tuple[float, float]:
        """``(low, high)``: the values a frame's column may take."""
        return (self.low, self.high)


_RECORDS: dict[str, Metric] = {}


@dataclass(frozen=True)
class FrameBatch:
    """What a record's ``compute`` reads of one scored batch (every array ``(N, H, W)``).

    Attributes
    ----------
    pred, gt : numpy.ndarray
        The prediction and the ground truth (metres, 0 = no truth).
    scored : numpy.ndarray
        The task's pixels (the hole; under densify-v1 every pixel the input lacks); score
        where ``scored & (gt > 0)``.
    inputs : numpy.ndarray
        What the method was given (NaN = to fill).
    low, high : numpy.ndarray or None
        The method's interval, None for a method without one.
    levels : dict or None
        ``{nominal coverage: (low, high)}``, the interval at each level of the reliability
        diagram (:data:`~inpaintenv.metrics.CALIBRATION_LEVELS`), when the method gives one.
    cache : dict
        Where records computed from one quantity share it (e.g. AUSE and AURG one curve).
    """

    pred: np.ndarray
    gt: np.ndarray
    scored: np.ndarray
    inputs: np.ndarray
    low: np.ndarray | None = None
    high: np.ndarray | None = None
    levels: dict[float, tuple[np.ndarray, np.ndarray]] | None = None
    cache: dict[Any, Any] = field(default_factory=dict, compare=False, repr=False)


def computed_metrics(batch: FrameBatch) -> dict[str, np.ndarray]:
    """Every record with a ``compute`` on ``batch`` (those that need an interval only with one): ``(N,)`` each."""
    out = {}
    for record in metric_records(computed=True):
        if record.needs_interval and batch.low is None:
            continue
        values = np.asarray(record.compute(batch), dtype=np.float64).reshape(-1)
        if values.shape != (len(batch.pred),):
            raise InvalidInputError(f"metric {record.name!r} computed {values.size} values for {len(batch.pred)} frames")
        out[record.name] = values
    return out


def register_metric(record: Metric) -> Metric:
    """Add ``record`` (a new name, or a record replacing the one of its name) and return it."""
    if not isinstance(record, Metric):
        raise InvalidInputError(f"a metric record must be a Metric, got {type(record).__name__}")
    _RECORDS[record.name] = record
    return record


def metric_record(name: str) -> Metric:
    """The record of column ``name``; one error listing the known ones otherwise."""
    try:
        return _RECORDS[name]
    except KeyError:
        raise UnknownNameError(f"no metric {name!r}; known: {', '.join(_RECORDS)}") from None


def metric_records(group: Any = ..., *, computed: bool | None = None) -> list[Metric]:
    """Every record in order of registration, or those of table ``group`` in table order (``rank``);
    ``computed``: only those with (True) or without (False) a ``compute``."""
    out = [r for r in _RECORDS.values() if (group is ... or r.group == group)
           and (computed is None or (r.compute is not None) == computed)]
    return out if group is ... else sorted(out, key=lambda r: r.rank)  # sorted is stable: then registration


#: The study's Table I/II columns first, in its order.
_STUDY_ORDER = {"hole_rmse": 0, "hole_psnr": 1, "all_rmse": 2, "all_psnr": 3, "hole_mae": 4, "hole_irmse": 5}


def _depth_records() -> None:
    """The columns of :func:`~inpaintenv.metrics.frame_metrics`."""
    where = {"hole": "hole pixels with ground truth", "all": "pixels with ground truth",
             "unmeasured": "pixels with ground truth the input did not measure"}
    # A prediction and its truth both lie in [0, DEPTH_LIMIT] where scored, so an error is at most
    # DEPTH_LIMIT m; an inverse error has no bound (the truth may be near 0 m); a PSNR follows
    # from its RMSE and the run's max_depth (inpaintenv.values.rows checks the two agree).
    error, inverse = (0.0, DEPTH_LIMIT), (0.0, math.inf)
    for region in ("hole", "all", "unmeasured"):
        frames = {"hole": "task", "all": "all", "unmeasured": "task"}[region]
        count = f"{region}_count"
        table = "depth" if region != "unmeasured" else "scan"
        shown = {"hole": ("rmse", "psnr", "mae", "irmse"), "all": ("rmse", "psnr"),
                 "unmeasured": ("rmse", "mae")}[region]
        specs = [("rmse", "RMSE", "m", ".2f", "rms", False, error, "root mean squared error (m)"),
                 ("mae", "MAE", "m", ".2f", "mean", False, error, "mean absolute error (m)"),
                 ("irmse", "iRMSE", "1/km", ".1f", "rms", False, inverse, "RMSE of inverse depth (1/km)"),
                 ("imae", "iMAE", "1/km", ".1f", "mean", False, inverse, "MAE of inverse depth (1/km)"),
                 ("psnr", "PSNR", "dB", ".1f", "psnr", True, (-math.inf, math.inf),
                  "20 log10(max_depth / RMSE) (dB)")]
        for key, short, unit, fmt, pool, better, (low, high), what in specs:
            if region == "unmeasured" and key in ("irmse", "imae"):
                continue
            register_metric(Metric(
                f"{region}_{key}", f"{what} over the frame's {where[region]}", pool, better, unit,
                f"{region} {short} ({unit})", fmt, low, high, count, frames, table if key in shown else None,
                rank=_STUDY_ORDER.get(f"{region}_{key}", 100)))
    for key, short, unit, fmt, pool in (("rmse", "RMSE", "mm", ".0f", "rms"), ("mae", "MAE", "mm", ".0f", "mean"),
                                         ("irmse", "iRMSE", "1/km", ".2f", "rms"),
                                         ("imae", "iMAE", "1/km", ".2f", "mean")):
        register_metric(Metric(
            f"kitti_{key}", f"KITTI depth completion's {short} over every pixel with ground truth, in its units",
            pool, False, unit, f"KITTI {short} ({unit})", fmt, 0.0, 1000.0 * DEPTH_LIMIT if unit == "mm" else math.inf,
            "all_count", "every", "scan"))


def _interval_records() -> None:
    """The columns of :func:`~inpaintenv.metrics.interval_metrics` (its module docstring defines them)."""
    # Keeping a fraction f keeps at least f of the pixels, so its RMSE is at most sqrt(1/f) times the
    # whole task's: the cut at 80 % is at least 1 - sqrt(1/0.8), an area at most the mean of sqrt(1/f).
    share, ratio, kept = (0.0, 1.0), (0.0, math.inf), (0.0, DEPTH_LIMIT)
    area, cut = (0.0, float(np.mean(np.sqrt(1.0 / np.asarray(KEEP_GRID))))), (1.0 - math.sqrt(1.0 / 0.8), 1.0)
    specs = [
        ("hole_coverage", "share of the task's pixels whose truth lies in the interval", "mean", True, "share",
         "hole coverage", ".1%", share, "interval"),
        ("hole_interval_width", "mean high - low over the task's pixels", "mean", False, "m",
         "interval width (m)", ".2f", ratio, "interval"),
        ("rmse_keep_90", "RMSE of the 90 % narrowest intervals' pixels", "frames", False, "m", None, ".2f", kept, None),
        ("rmse_keep_80", "RMSE of the 80 % narrowest intervals' pixels", "frames", False, "m",
         "hole RMSE, 80 % most confident (m)", ".2f", kept, "interval"),
        ("rmse_keep_50", "RMSE of the 50 % narrowest intervals' pixels", "frames", False, "m", None, ".2f", kept, None),
        ("rmse_cut_80", "1 - rmse_keep_80 / the task's RMSE", "frames", True, "", None, ".3f", cut, None),
        ("rejection_auc", "mean over keep fractions 0.05..1 of RMSE kept / RMSE", "frames", False, "",
         "rejection AUC", ".3f", area, "interval"),
        ("border_rmse_keep_90", "RMSE of the 90 % pixels nearest the hole border", "frames", False, "m", None, ".2f",
         kept, None),
        ("border_rmse_keep_80", "RMSE of the 80 % pixels nearest the hole border", "frames", False, "m",
         "hole RMSE, 80 % nearest border (m)", ".2f", kept, "interval"),
        ("border_rmse_keep_50", "RMSE of the 50 % pixels nearest the hole border", "frames", False, "m", None, ".2f",
         kept, None),
        ("border_rejection_auc", "rejection_auc ranked by distance to the border", "frames", False, "", None, ".3f",
         area, None),
        ("oracle_rmse_keep_80", "RMSE of the 80 % pixels of smallest error", "frames", False, "m", None, ".2f", kept,
         None),
        ("oracle_rejection_auc", "rejection_auc ranked by the true error", "frames", False, "", None, ".3f", area,
         None),
    ]
    shown = ["hole_coverage", "hole_interval_width", "rmse_keep_80", "border_rmse_keep_80", "rejection_auc"]
    for name, reduce, pool, better, unit, label, fmt, (low, high), group in specs:
        register_metric(Metric(name, reduce, pool, better, unit, label or name, fmt, low, high, "task", "task", group,
                               rank=shown.index(name) if name in shown else 100))


_depth_records()
_interval_records()
