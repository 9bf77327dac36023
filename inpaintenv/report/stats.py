"""Bootstrap confidence intervals of per-frame means.

Used by every table of the package (:mod:`inpaintenv.report.tables`): ``evaluate``'s and the
benchmark's. An interval needs at least two frames: with one frame the bounds are NaN
(written as ``null`` / an empty cell), never the mean itself, so a single frame cannot
pass for a zero-width interval.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..exceptions import InvalidInputError

__all__ = ["FEW_FRAMES", "bootstrap_mean_ci", "bootstrap_ratio_ci"]

#: Below this many frames an interval is marked as rough: a percentile bootstrap from so
#: few frames is too narrow (a nominal 95 % interval from 5 skewed per-frame errors covers
#: the true mean ~81 % of the time, from 10 ~89 %; docs/scripts/bootstrap_coverage.py),
#: so tables flag it instead of presenting it like the others.
FEW_FRAMES = 10

_NAN = float("nan")


def bootstrap_mean_ci(
    values: Sequence[float] | np.ndarray,
    *,
    confidence: float = 0.95,
    n_resamples: int = 2000,
    seed: int = 0,
) -> tuple[float, float, float]:
    """Mean of ``values`` and its percentile-bootstrap interval over frames.

    NaN values (e.g. frames whose hole holds no ground truth) are dropped first.

    Parameters
    ----------
    values : array-like of float
        One value per frame.
    confidence : float
        Coverage of the interval, in (0, 1).
    n_resamples : int
        Bootstrap resamples (vectorised: one ``(n_resamples, n)`` index draw).
    seed : int
        Seed of the resampling, so reports are reproducible.

    Returns
    -------
    (mean, low, high) : tuple of float
        NaN for all three when no finite value remains; ``low`` and ``high`` are NaN for
        a single frame (an interval from one frame does not exist).
    """
    _check_confidence(confidence)
    v = np.asarray(values, dtype=np.float64).reshape(-1)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return _NAN, _NAN, _NAN
    mean = float(v.mean())
    if v.size == 1:
        return mean, _NAN, _NAN
    means = v[_resample(v.size, n_resamples, seed)].mean(axis=1)
    return (mean, *_percentile_interval(means, confidence))


def bootstrap_ratio_ci(
    a: Sequence[float] | np.ndarray,
    b: Sequence[float] | np.ndarray,
    *,
    confidence: float = 0.95,
    n_resamples: int = 2000,
    seed: int = 0,
) -> tuple[float, float, float]:
    """``mean(a) / mean(b)`` and its paired percentile-bootstrap interval.

    ``a[i]`` and ``b[i]`` belong to one frame (e.g. two methods on the same frame and
    mask), so each resample draws frames and keeps the pairs together.

    Parameters
    ----------
    a, b : array-like of float
        Paired per-frame values of one length, finite.
    confidence, n_resamples, seed
        As for :func:`bootstrap_mean_ci`.

    Returns
    -------
    (ratio, low, high) : tuple of float
        ``low`` and ``high`` are NaN for a single pair. A ratio to a mean of 0 does not
        exist: all three are NaN when ``mean(b)`` is 0, and the bounds are NaN when some
        resample's mean of ``b`` is 0 (its ratio, and so the interval, is undefined).
    """
    _check_confidence(confidence)
    a = np.asarray(a, dtype=np.float64).reshape(-1)
    b = np.asarray(b, dtype=np.float64).reshape(-1)
    if a.size != b.size or a.size == 0:
        raise InvalidInputError(f"a and b must be non-empty and paired, got {a.size} and {b.size} values")
    if b.mean() == 0:
        return _NAN, _NAN, _NAN
    ratio = float(a.mean() / b.mean())
    if a.size == 1:
        return ratio, _NAN, _NAN
    idx = _resample(a.size, n_resamples, seed)
    denominators = b[idx].mean(axis=1)
    if not denominators.all():
        return ratio, _NAN, _NAN
    return (ratio, *_percentile_interval(a[idx].mean(axis=1) / denominators, confidence))


def _check_confidence(confidence: float) -> None:
    if not 0.0 < confidence < 1.0:
        raise InvalidInputError(f"confidence must be in (0, 1), got {confidence}")


def _resample(n: int, n_resamples: int, seed: int) -> np.ndarray:
    """``(n_resamples, n)`` indices drawn with replacement (one vectorised draw)."""
    return np.random.default_rng(seed).integers(0, n, size=(n_resamples, n))


def _percentile_interval(samples: np.ndarray, confidence: float) -> tuple[float, float]:
    alpha = (1.0 - confidence) / 2.0
    low, high = np.quantile(samples, [alpha, 1.0 - alpha])
    return float(low), float(high)
