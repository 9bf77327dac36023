"""Per-pixel intervals for any fitted inpainter: drive-grouped split conformal prediction.

:class:`ConformalIntervalInpainter` wraps a fitted inpainter (its module docstring,
``estimators.intervals._conformal``, says how it calibrates); :func:`release_intervals`
loads a shipped release in its shipped calibration (``estimators/pretrained/intervals/``).
The calibration maths (``scored_residuals``, ``scale_from``, ``balanced_scale``,
``residual_quantiles``) and the per-bin (Mondrian) quantiles (``fit_condition``, ``cell_of``,
``cell_quantiles``, ``check_edges``) are public for studies of other calibrations
(``experiments/interval_calibration.py lodo``).
"""

from ._calibration import balanced_scale, residual_quantiles, scale_from, scored_residuals
from ._mondrian import cell_of, cell_quantiles, check_edges, fit_condition
from ._conformal import SIGNALS, WEIGHTINGS, ConformalIntervalInpainter, weighted_quantiles
from ._releases import ShippedIntervals, default_intervals, load_intervals, release_intervals, shipped_intervals

__all__ = ["SIGNALS", "WEIGHTINGS", "ConformalIntervalInpainter", "ShippedIntervals", "balanced_scale", "cell_of",
           "cell_quantiles", "check_edges", "default_intervals", "fit_condition", "load_intervals", "release_intervals", "residual_quantiles", "scale_from", "scored_residuals", "shipped_intervals",
           "weighted_quantiles"]
