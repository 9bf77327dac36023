"""Per-pixel intervals for any fitted inpainter: drive-grouped split conformal prediction.

:class:`ConformalIntervalInpainter` wraps a fitted inpainter (its module docstring,
``estimators.intervals._conformal``, says how it calibrates); :func:`release_intervals`
loads a shipped release in its shipped calibration (``estimators/pretrained/intervals/``).
"""

from ._conformal import SIGNALS, WEIGHTINGS, ConformalIntervalInpainter, weighted_quantiles
from ._releases import default_intervals, load_intervals, release_intervals, shipped_intervals

__all__ = ["SIGNALS", "WEIGHTINGS", "ConformalIntervalInpainter", "default_intervals", "load_intervals", "release_intervals", "shipped_intervals",
           "weighted_quantiles"]
