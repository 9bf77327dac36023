"""Scorers for ``GridSearchCV`` / ``cross_validate`` (greater is better).

A scorer is called as ``scorer(estimator, X, y=None)``. Without ``y``, ``X`` is ground
truth that is corrupted with a fixed, seeded occlusion protocol (as in
:meth:`BaseInpainter.score`); with ``y``, ``X`` is the corrupted input and ``y`` the
ground truth. ``estimator.score`` already returns ``-hole RMSE``; use these for the other
metrics, e.g. ``GridSearchCV(est, grid, scoring=hole_mae_scorer)`` or
``scoring={"rmse": hole_rmse_scorer, "psnr": hole_psnr_scorer}``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from inpaintenv.masks import get_protocol
from inpaintenv.metrics import METRIC_NAMES, REGIONS, aggregate

from .base import SCORE_PROTOCOL, SCORE_SEED, BaseInpainter
from inpaintenv.exceptions import InvalidInputError, InvalidTypeError

__all__ = [
    "InpaintScorer",
    "all_rmse_scorer",
    "hole_mae_scorer",
    "hole_psnr_scorer",
    "hole_rmse_scorer",
    "make_inpaint_scorer",
]

#: Metrics where smaller is better; the scorer negates them.
_ERRORS = ("rmse", "mae", "irmse", "imae")


class InpaintScorer:
    """A picklable scorer ``(estimator, X, y=None) -> float`` for one metric.

    Build it with :func:`make_inpaint_scorer`.
    """

    def __init__(self, metric: str, protocol: str, seed: int):
        self.metric = metric
        self.protocol = protocol
        self.seed = seed
        self._sign = -1.0 if metric.split("_", 1)[1] in _ERRORS else 1.0

    def __call__(self, estimator: Any, X: Any, y: Any = None) -> float:
        if not isinstance(estimator, BaseInpainter):
            raise InvalidTypeError(
                f"an inpaint scorer needs an estimators.BaseInpainter, got {type(estimator).__name__}"
            )
        per_frame = estimator.score_frames(X, y, protocol=self.protocol, seed=self.seed)
        value = aggregate(per_frame)[self.metric]
        if np.isnan(value):
            raise InvalidInputError(f"no frame has ground truth for {self.metric!r}; nothing to score")
        return self._sign * float(value)

    def __repr__(self) -> str:
        sign = "-" if self._sign < 0 else ""
        return f"make_inpaint_scorer({self.metric!r}, protocol={self.protocol!r}, seed={self.seed})  # {sign}{self.metric}"


def make_inpaint_scorer(
    metric: str = "hole_rmse", protocol: str = SCORE_PROTOCOL, seed: int = SCORE_SEED,
) -> Callable[..., float]:
    """Make a greater-is-better scorer from a metric of :mod:`inpaintenv.metrics`.

    Parameters
    ----------
    metric : str, default="hole_rmse"
        ``{region}_{name}`` with region in ``("hole", "all")`` and name in
        ``("rmse", "mae", "irmse", "imae", "psnr")``. Error metrics are negated.
    protocol : str, default="rect-v1"
        Occlusion protocol used when the scorer gets no ``y``.
    seed : int, default=0
        Evaluation seed used when the scorer gets no ``y`` (frame ``i`` gets mask ``i``).

    Returns
    -------
    callable
        ``scorer(estimator, X, y=None) -> float``, usable as ``scoring=``.
    """
    known = [f"{r}_{m}" for r in REGIONS for m in METRIC_NAMES]
    if metric not in known:
        raise InvalidInputError(f"unknown metric {metric!r}; choose one of {', '.join(known)}")
    get_protocol(protocol)  # fail now on an unknown protocol, not inside a CV loop
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InvalidInputError(f"seed must be a non-negative integer, got {seed!r}")
    return InpaintScorer(metric, protocol, int(seed))


hole_rmse_scorer = make_inpaint_scorer("hole_rmse")
hole_mae_scorer = make_inpaint_scorer("hole_mae")
hole_psnr_scorer = make_inpaint_scorer("hole_psnr")
all_rmse_scorer = make_inpaint_scorer("all_rmse")
