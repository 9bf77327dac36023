"""The calibration maths of :class:`~estimators.intervals.ConformalIntervalInpainter`.

The scored pixels' signals and residuals, the log-linear scale fitted on them, and the
(weighted) quantiles of the normalised residuals; the module docstring of
``estimators.intervals._conformal`` says what each is for.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np

from inpaintenv.data.base import DepthDataset, Subset, as_dataset
from inpaintenv.exceptions import InvalidInputError, InvalidTypeError
from inpaintenv.data.inputs import method_input
from inpaintenv.masks import get_protocol
from inpaintenv.metrics import border_distance
from inpaintenv.values.interval_calibration import (DENSITY_WINDOW, DEPTH_FLOOR, FAR_DISTANCE, N_LEVELS,
                                                    RESIDUAL_FLOOR, SCALE_LOG_RANGE, SPREAD_FLOOR)

from ..base import SCORE_CHUNK, training_drives

__all__ = ["balanced_scale", "calibration_protocols", "check_enough_pixels", "checked_prediction", "exact_quantile",
           "features", "fit_scale", "grouped", "residual_quantiles", "scale_from", "scored_residuals", "weighted_quantiles"]


def features(signals: Sequence[str], pred: np.ndarray, hole: np.ndarray, second: np.ndarray | None) -> np.ndarray:
    """``(n_hole_pixels, 1 + len(signals))`` design matrix of the hole pixels (intercept first).

    ``"far"`` is 1 where the border distance exceeds :data:`FAR_DISTANCE` px (a hole, not the gaps
    between a scan's lines), else 0: its coefficient is set by :func:`balanced_scale`. ``"density"``
    is the share of measured pixels (not to fill) in the :data:`DENSITY_WINDOW`-px square around the pixel,
    ``"frame_density"`` that share over the rows of the frame with a measurement (the same at every pixel).
    """
    cols = [np.ones(int(hole.sum()))]
    near = np.log1p(border_distance(hole)[hole].astype(np.float64)) if {"border", "far"} & set(signals) else None
    for s in signals:
        if s == "border":
            cols.append(near)
        elif s == "far":
            cols.append((near > math.log1p(FAR_DISTANCE)).astype(np.float64))
        elif s == "frame_density":  # the measured share of the rows with a measurement: one value per frame
            rows = ~hole.all(axis=1)
            cols.append(np.full(cols[0].size, float((~hole[rows]).mean()) if rows.any() else 0.0))
        elif s == "density":
            import cv2  # lazy, as border_distance's

            cols.append(cv2.blur((~hole).astype(np.float32), (DENSITY_WINDOW, DENSITY_WINDOW))[hole].astype(np.float64))
        elif s == "depth":
            cols.append(np.log(np.maximum(pred[hole].astype(np.float64), DEPTH_FLOOR)))
        else:  # spread
            cols.append(np.log(np.abs(pred[hole].astype(np.float64) - second[hole]) + SPREAD_FLOOR))
    return np.stack(cols, axis=1)


def weighted_quantiles(values: np.ndarray, weights: np.ndarray, levels: Sequence[float]) -> np.ndarray:
    """The smallest ``v`` of ``values`` whose weighted share at or below it reaches each level.

    With equal weights this is ``np.quantile(values, levels, method="inverted_cdf")``.
    """
    order = np.argsort(values)  # ties need no stable order: tied values are the same value
    cdf = np.cumsum(weights[order], dtype=np.float64)
    cdf /= cdf[-1]
    # A level hit up to rounding must not step to the next value.
    idx = np.searchsorted(cdf, np.asarray(levels, dtype=np.float64) - 1e-12, side="left")
    return values[order[np.minimum(idx, len(order) - 1)]]


def calibration_protocols(protocol: Any) -> list[Any]:
    """The masks protocols named by ``protocol``: one name, or several joined by ``+`` (pooled)."""
    if not isinstance(protocol, str) or not protocol:
        raise InvalidInputError(f"protocol must be a protocol name or names joined by '+', got {protocol!r}")
    return [get_protocol(name) for name in protocol.split("+")]


def _task_batches(dataset: DepthDataset, protocol: Any, seed: int) -> Iterator[tuple[np.ndarray, ...]]:
    """``(input, ground truth, pixels to fill, pixels scored)`` batches of ``dataset`` under ``protocol``.

    Scored are the protocol's task pixels, as ``evaluate`` scores them: every pixel the input
    lacks under ``densify-v1`` (task ``unmeasured``), else the hole (on a map, the same set).
    """
    kind = getattr(dataset, "input_kind", "map")
    for start in range(0, len(dataset), SCORE_CHUNK):
        idx = range(start, min(start + SCORE_CHUNK, len(dataset)))
        inputs, gt = dataset.load_pairs(idx)
        hole = protocol.masks(dataset.frame_shape, seed, idx)
        x = method_input(inputs, hole, kind)
        fill = np.isnan(x)
        yield x, gt, fill, (fill if protocol.task == "unmeasured" else hole & fill)


def scored_residuals(model: Any, dataset: DepthDataset, signals: tuple[str, ...], second: Any, protocol: str,
                     seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The signals (design matrix), absolute residuals and frame number of ``model``'s every scored pixel.

    The scored pixels are each protocol's task pixels (:func:`_task_batches`); the signals are
    those of every pixel to fill, as ``predict_interval`` sees them. Under pooled protocols
    (``"densify-v1+rect-v1"``) each (protocol, frame) is a frame of its own.
    """
    feats, resid, frame = [], [], []
    start = 0
    for proto in calibration_protocols(protocol):
        for x, gt, fill, task in _task_batches(dataset, proto, seed):
            pred = np.asarray(model.predict(x), dtype=np.float32)
            other = np.asarray(second.predict(x), dtype=np.float64) if second is not None else None
            for k in range(len(x)):
                scored = task[k] & (gt[k] > 0)
                if not scored.any():
                    continue
                f = features(signals, pred[k], fill[k], None if other is None else other[k])
                feats.append(f[scored[fill[k]]])
                resid.append(np.abs(gt[k][scored].astype(np.float64) - pred[k][scored]))
                frame.append(np.full(resid[-1].size, start + k, dtype=np.int64))
            start += len(x)
    if not resid:
        raise InvalidInputError("no calibration frame has ground truth inside its holes; nothing to calibrate on")
    return np.concatenate(feats), np.concatenate(resid), np.concatenate(frame)


def fit_scale(F: np.ndarray, r: np.ndarray, seed: int, max_fit_pixels: int) -> np.ndarray:
    """Least squares of ``log(r + 0.05 m)`` on ``F``, on at most ``max_fit_pixels`` pixels drawn with ``seed``."""
    rng = np.random.default_rng(int(seed))
    take = rng.choice(len(r), max_fit_pixels, replace=False) if len(r) > max_fit_pixels else slice(None)
    coef, *_ = np.linalg.lstsq(F[take], np.log(r[take] + RESIDUAL_FLOOR), rcond=None)
    return coef


def balanced_scale(F: np.ndarray, r: np.ndarray, frame: np.ndarray, signals: Sequence[str], seed: int,
                   max_fit_pixels: int, weighting: str, coverage: float) -> np.ndarray:
    """:func:`fit_scale`, then with ``"far"`` its coefficient moved so that the far and the near
    pixels' normalised residuals have the same quantile at ``coverage``: each group is then
    covered alike (Mondrian conformal over the two groups), whatever share of the calibration it is.
    """
    coef = fit_scale(F, r, seed, max_fit_pixels)
    if "far" not in signals:
        return coef
    j = 1 + list(signals).index("far")
    normed = r / scale_from(coef, F)
    far = F[:, j] > 0
    if far.any() and not far.all():
        q_far = residual_quantiles(normed[far], frame[far], weighting, coverage)[1]
        q_near = residual_quantiles(normed[~far], frame[~far], weighting, coverage)[1]
        coef[j] += math.log(q_far / q_near)
    return coef


def scale_from(coef: np.ndarray, F: np.ndarray) -> np.ndarray:
    """The scale (metres) of each row of ``F``."""
    # Clipped so that one extreme signal never gives a zero or an overflowing width.
    return np.exp(np.clip(F @ coef, *SCALE_LOG_RANGE))


def check_enough_pixels(n: int, coverage: float) -> int:
    """The rank ``ceil((n + 1) c)`` of the split-conformal quantile; refused when it exceeds ``n``."""
    k = math.ceil((n + 1) * coverage)
    if k > n:
        raise InvalidInputError(f"{n} calibration pixels are too few for a {coverage:g} interval (needs "
                                f"{math.ceil(coverage / (1 - coverage))})")
    return k


def exact_quantile(sorted_normed: np.ndarray, coverage: float) -> float:
    """The split-conformal quantile: the ``ceil((n + 1) c)``-th smallest of the sorted normalised residuals."""
    k = check_enough_pixels(sorted_normed.size, coverage)
    return max(float(sorted_normed[k - 1]), 1e-6)


def residual_quantiles(normed: np.ndarray, frame: np.ndarray, weighting: str,
                       coverage: float) -> tuple[np.ndarray, float]:
    """The normalised residuals' quantiles at :data:`N_LEVELS` levels, and ``q`` at ``coverage``.

    ``"pixel"``: every pixel alike, ``q`` the exact order statistic; ``"frame"``: each
    frame's pixels weigh ``1 / n_k`` (``frame`` numbers the frames).
    """
    levels = np.linspace(0.0, 1.0, N_LEVELS)
    if weighting == "pixel":
        ordered = np.sort(normed)  # one sort for both: np.quantile(..., method="higher") reads these indices
        return ordered[np.ceil(levels * (ordered.size - 1)).astype(np.int64)], exact_quantile(ordered, coverage)
    check_enough_pixels(normed.size, coverage)  # refused as the pixel weighting is
    per_frame = np.bincount(frame)  # frame numbers are small non-negative integers
    found = weighted_quantiles(normed, 1.0 / per_frame[frame], np.append(levels, coverage))
    return found[:-1], max(float(found[-1]), 1e-6)


def grouped(X: Any, groups: Sequence[Any] | None) -> DepthDataset:
    """``X`` as a dataset whose frames carry drive ids (``groups`` when given), or one error saying what is missing."""
    dataset = as_dataset(X)
    if len(dataset) == 0:
        raise InvalidInputError("cannot calibrate on an empty dataset")
    if groups is not None:
        if isinstance(groups, str) or len(groups) != len(dataset):
            raise InvalidInputError(f"groups must give one drive id per frame ({len(dataset)}), got {groups!r:.80}")
        dataset = Subset(dataset, np.arange(len(dataset)))  # a view: the caller's groups stay as they are
        dataset.groups = np.asarray([str(g) for g in groups])
    elif training_drives(dataset) is None:
        raise InvalidInputError("calibration frames need drive ids: pass groups=[drive of each frame] (whole "
                                "drives the base never saw) or a dataset whose frames carry them (KittiDepth)")
    return dataset


def checked_prediction(pred: Any, x: np.ndarray, method: str, X: Any, base: Any = None) -> np.ndarray:
    """``pred`` as float32 of ``x``'s shape, or one error naming ``method`` and the first bad frame.

    ``base``: the estimator that predicted it (None: a prediction the caller passed). A NaN or
    inf prediction would give NaN bounds, a complex one would lose its imaginary part in the
    cast: neither is an interval.
    """
    whose = "prediction" if base is None else f"the prediction of {type(base).__name__}"
    arr = np.asarray(pred)
    if arr.dtype.kind not in "fiu":
        raise InvalidTypeError(f"{method}: {whose} has dtype {arr.dtype}; it must be real depth in metres")
    if arr.size != x.size:
        raise InvalidInputError(f"{whose} has shape {arr.shape}, X {np.shape(X)}: pass predict(X)")
    with np.errstate(over="ignore"):
        out = arr.astype(np.float32).reshape(x.shape)
    finite = np.isfinite(out).reshape(len(out), -1).all(axis=1)
    if not finite.all():
        k = int(np.argmin(finite))
        raise InvalidInputError(f"{method}: {whose} has NaN or inf depth in frame {k} "
                                f"({int(np.count_nonzero(~np.isfinite(out[k])))} pixels); no interval around it")
    return out
