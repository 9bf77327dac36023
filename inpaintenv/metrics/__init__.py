"""Scoring: depth errors per frame and their aggregates, where the error comes from, and intervals.

Every per-frame metric column is one record (:class:`Metric`, ``_records``: how a frame
reduces it, how frames pool it, its direction, unit, label, format and range) that
``evaluate``, the tables and the scorer read. Depth metrics (hole / unmeasured / all RMSE,
MAE, iRMSE, iMAE, PSNR, KITTI's own four) are described in ``_depth``; per-pixel intervals (coverage, width, rejection curves) in
``_intervals``. Every name has one public path: ``inpaintenv.metrics.<name>``.
"""

from ._depth import (
    EXTRA_COLUMNS,
    KITTI_METRICS,
    METRIC_NAMES,
    REGIONS,
    UNFILLED,
    UNMEASURED_METRICS,
    ScoredPixels,
    aggregate,
    check_unfilled,
    frame_metrics,
    psnr_of,
    task_of,
)
from ._depth_bins import DEPTH_BIN_EDGES, depth_binned_errors
from ._devkit import interpolate_background
from ._sparsification import CALIBRATION_LEVELS, CONVENTIONS, REMOVED, auce, calibration, sparsification
from ._records import POOLS, FrameBatch, Metric, computed_metrics, metric_record, metric_records, register_metric
from ._intervals import (
    INTERVAL_COLUMNS,
    KEEP_FRACTIONS,
    KEEP_GRID,
    Coverage,
    as_coverage,
    border_distance,
    check_coverage,
    check_interval,
    interval_from_std,
    interval_metrics,
    normal_quantile,
    rejection_curve,
)

__all__ = [
    "CALIBRATION_LEVELS", "CONVENTIONS", "REMOVED", "auce", "calibration", "sparsification", "DEPTH_BIN_EDGES", "EXTRA_COLUMNS", "INTERVAL_COLUMNS", "KEEP_FRACTIONS", "KEEP_GRID", "KITTI_METRICS",
    "METRIC_NAMES", "POOLS", "REGIONS", "FrameBatch", "Metric", "UNFILLED", "UNMEASURED_METRICS", "Coverage", "ScoredPixels", "aggregate",
    "as_coverage", "border_distance", "check_coverage", "check_interval", "check_unfilled", "computed_metrics", "depth_binned_errors",
    "frame_metrics", "interpolate_background", "interval_from_std", "interval_metrics", "metric_record", "metric_records", "normal_quantile", "psnr_of",
    "register_metric", "rejection_curve", "task_of",
]
