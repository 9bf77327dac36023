"""Per-pixel intervals for any fitted inpainter: drive-grouped split conformal prediction.

:class:`ConformalIntervalInpainter` wraps a fitted inpainter (classical or learned) the
way scikit-learn's ``CalibratedClassifierCV(cv="prefit")`` wraps a fitted classifier:
``fit`` is only the *calibration* step, on frames of drives the base model never saw.

Calibration (``fit``): each calibration frame is occluded with the project's masks
protocol (``rect-v1``, seed 0 by default, frame ``i`` gets mask ``i``, as ``score`` does),
the base fills it, and on every hole pixel with ground truth the *normalised residual*
``|gt - pred| / scale`` is recorded. ``scale`` is a small log-linear model of cheap
signals of the pixel, fitted by least squares of ``log(|residual| + 0.05 m)`` on them:

``"border"``
    ``log(1 + d)``, ``d`` the distance in pixels to the hole's border
    (:func:`inpaintenv.metrics.border_distance`): the middle of a large hole errs more.
``"depth"``
    ``log(max(pred, 1 m))``: far pixels err more.
``"spread"``
    ``log(|pred - second| + 0.1 m)``, ``second`` a second cheap fill
    (``spread_method``, a registered classical method): where two fills disagree, the
    scene is ambiguous.

The interval of nominal coverage ``c`` is ``pred ± q_c · scale`` (low clipped at 0 m),
``q_c`` a quantile of the normalised residuals, weighted in one of two ways
(``weighting``):

``"frame"`` (default)
    Every calibration frame weighs the same (each of its ``n_k`` scored pixels ``1 / n_k``),
    so the mean over frames of each frame's coverage (the benchmark's ``hole_coverage``) is
    ``c`` on the calibration frames, even where the frames with large holes are the easier
    ones; an estimate, without split conformal's finite-sample correction.
``"pixel"``
    Every scored pixel weighs the same: the split-conformal quantile with the finite-sample
    correction (the ``ceil((n + 1) c)``-th smallest of ``n``), whose guarantee is for a pixel
    drawn from all the test pixels pooled.

The weighted residuals are kept as 2001 quantiles: any coverage can be asked (rounded up, by at most 0.05 %).
With ``condition`` (``"distance"`` to the nearest measurement, or ``"depth"``) ``q_c`` is taken per bin
of the variable (Mondrian conformal, ``._mondrian``), the pooled one where a bin has too few pixels.

The guarantee is marginal over pixels of frames exchangeable with the calibration frames,
so **the base model must never have seen the calibration drives**: ``fit`` takes whole
drives (``groups``) and refuses drives the base records in ``training_drives_``.

On single scans (``input_kind`` ``"scan"`` or a density variant) the scored pixels are the protocol's
task: under ``densify-v1`` every pixel the scan did not measure, under a hole protocol the hole cut
out of the scan; ``"densify-v1+rect-v1"`` pools both. The maths is in ``._calibration``, the file's
reading and writing in ``._persistence`` and ``._calibration_file``.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from sklearn.base import BaseEstimator, MetaEstimatorMixin
from sklearn.utils.validation import check_is_fitted

from inpaintenv.data.base import DepthDataset
from inpaintenv.data.inputs import input_kind
from inpaintenv.exceptions import InvalidInputError, InvalidTypeError
from inpaintenv.metrics import check_coverage, normal_quantile

from .._constraints import Check, ConstrainedParams, InstanceOf, Integer, Options
from ..base import SCORE_PROTOCOL, SCORE_SEED, BaseInpainter, check_inpaint_input
from ._bases import CLASSICAL_FILLS, make_base
from ._calibration import (balanced_scale, calibration_protocols, checked_prediction, exact_quantile, features,
                           grouped, residual_quantiles, scale_from, scored_residuals, weighted_quantiles)
from ._calibration_file import CONDITIONS, DEFAULT_SIGNALS, SIGNALS, WEIGHTINGS
from ._mondrian import (cell_of, cell_quantiles, check_condition, check_edges, fit_condition, stored_quantile,
                        with_condition)
from ._persistence import CalibrationFileMixin

__all__ = ["ConformalIntervalInpainter", "SIGNALS", "WEIGHTINGS", "weighted_quantiles"]


def _check_signals(value: Any) -> None:
    """``signals``: a tuple (or list) of distinct names from :data:`SIGNALS`, possibly empty."""
    if isinstance(value, str) or not isinstance(value, (tuple, list)):
        raise InvalidTypeError(f"signals must be a tuple of names from {SIGNALS}, got {value!r}")
    if any(s not in SIGNALS for s in value) or len(set(value)) != len(value):
        raise InvalidInputError(f"signals must be distinct names from {SIGNALS}, got {tuple(value)!r}")


def _check_predictor(value: Any) -> None:
    """``estimator``: anything with ``predict(X)`` (a bare predictor is taken as is)."""
    if not callable(getattr(value, "predict", None)):
        raise InvalidTypeError(f"estimator must have predict(X), got {type(value).__name__}")


class ConformalIntervalInpainter(CalibrationFileMixin, ConstrainedParams, MetaEstimatorMixin, BaseEstimator):
    """Per-pixel intervals around a fitted inpainter, calibrated on drives it never saw.

    Parameters
    ----------
    estimator : fitted inpainter
        Any object with ``predict(X) -> (N, H, W)`` metres (a classical method, a loaded
        release). Never refitted; its prediction is returned unchanged.
    coverage : float, default=0.9
        Nominal coverage in (0, 1) of ``predict_interval`` without an argument and the
        coverage ``std`` refers to (see :meth:`predict`).
    signals : tuple of names in SIGNALS ("far" too), default=("border", "depth", "spread")
        The scale signals (see the module docstring); an empty tuple gives a constant
        width (plain split conformal).
    spread_method : str, default="scanline"
        Registered classical method giving the second fill of the ``"spread"`` signal;
        must fill differently from ``estimator`` (refused at ``fit`` when the spread is 0
        at every calibration pixel).
    protocol : str, default="rect-v1"
        Masks protocol occluding the calibration frames; ``"densify-v1+rect-v1"`` pools several.
    seed : int, default=0
        Protocol seed (frame ``i`` of the calibration set gets mask ``i``).
    max_fit_pixels : int, default=200000
        Pixels (drawn with ``seed``) the scale's least squares is fitted on; the quantiles
        use every calibration pixel.
    weighting : {"frame", "pixel"}, default="frame"
        How calibration pixels weigh in ``q``: each frame alike (the benchmark's mean over
        frames of the coverage is then ``coverage`` on the calibration frames) or each
        pixel alike (split conformal's finite-sample correction, for pooled pixels).
    condition : {None, "distance", "depth", "density"}, default=None
        The variable whose bins get a quantile each (distance to the nearest measurement, predicted
        depth, measured share around the pixel); None: one quantile for every pixel.
    condition_edges : sequence of float, optional
        The bins' edges (px or m; ``DEFAULT_EDGES`` of :mod:`inpaintenv.values.interval_calibration`).

    Attributes
    ----------
    coef_ : numpy.ndarray
        Intercept then one coefficient per signal of ``log scale``.
    residual_quantiles_ : numpy.ndarray
        The normalised residuals' quantiles at levels ``linspace(0, 1, 2001)`` (method "higher").
    quantile_ : float
        The conformal quantile ``q`` at ``coverage`` (exact order statistic).
    condition_ : dict or None
        With ``condition``: the edges and each bin's counts and quantiles (the file's ``condition``).
    calibration_ : dict
        What it was calibrated on: ``drives``, ``n_frames``, ``n_pixels``, ``coverage``,
        ``protocol``, ``seed``, ``base`` (the base's class), ``signals``, ``weighting``.

    Notes
    -----
    ``save(path, base=None)`` writes the calibration, never the base model, as one small
    JSON file; ``base`` says how ``load(path)`` rebuilds the base (a registered method name
    such as ``"scanline"`` or ``"pretrained"``, or a model folder; by default the base's
    class name, and then ``load`` needs ``estimator=``). ``load(path, estimator=None)``
    reads it around ``estimator``, whose class must be the one calibrated (both of
    :class:`~estimators.intervals._persistence.CalibrationFileMixin`).

    Examples
    --------
    >>> from inpaintenv.data import KittiDepth                      # doctest: +SKIP
    >>> from estimators.classical import ScanlineInpainter           # doctest: +SKIP
    >>> cal = KittiDepth(split="train", drives=["2011_09_30_drive_9018_sync"])  # doctest: +SKIP
    >>> wrapped = ConformalIntervalInpainter(ScanlineInpainter(), spread_method="nearest").fit(cal)  # doctest: +SKIP
    >>> low, high = wrapped.predict_interval(x)                     # doctest: +SKIP
    """

    def __init__(
        self, estimator: Any, coverage: float = 0.9, signals: tuple[str, ...] = DEFAULT_SIGNALS,
        spread_method: str = "scanline", protocol: str = SCORE_PROTOCOL, seed: int = SCORE_SEED,
        max_fit_pixels: int = 200_000, weighting: str = "frame", condition: str | None = None,
        condition_edges: Sequence[float] | None = None,
    ) -> None:
        self.estimator = estimator
        self.coverage = coverage
        self.signals = signals
        self.spread_method = spread_method
        self.protocol = protocol
        self.seed = seed
        self.max_fit_pixels = max_fit_pixels
        self.weighting = weighting
        self.condition = condition
        self.condition_edges = condition_edges

    # -- parameters --------------------------------------------------------------
    _parameter_constraints: dict[str, list[Any]] = {
        "coverage": [Check(check_coverage)],  # a number in (0, 1), as every coverage of the package
        "signals": [Check(_check_signals)],
        "estimator": [Check(_check_predictor)],
        "spread_method": [InstanceOf(str, "a registered method name")],
        "weighting": [Options(*WEIGHTINGS)],
        "protocol": [Check(calibration_protocols)],  # an unknown name lists the known protocols
        "seed": [Integer(0)],
        "max_fit_pixels": [Integer(10)],
        "condition": [None, Options(*CONDITIONS)],
        "condition_edges": [None, Check(check_edges)],
    }

    @staticmethod
    def _second_fill(name: str) -> Any:
        if name not in CLASSICAL_FILLS:
            raise InvalidInputError(f"spread_method must be a classical method ({', '.join(CLASSICAL_FILLS)}), got {name!r}")
        return make_base(name)

    #: Calibrates on whole drives: fit needs each frame's drive (``groups`` or a dataset's).
    _needs_drive_ids = True
    # Scored as every inpainter is, through its own predict (the filled depth, not the interval).
    score = BaseInpainter.score
    score_frames = BaseInpainter.score_frames

    def __sklearn_is_fitted__(self) -> bool:
        return hasattr(self, "calibration_")

    # -- calibration -------------------------------------------------------------
    def fit(self, X: Any, y: Any = None, *, groups: Sequence[Any] | None = None) -> ConformalIntervalInpainter:
        """Calibrate on ground-truth frames of whole drives the base model never saw.

        Parameters
        ----------
        X : DepthDataset, (N, H, W) array or sequence of (H, W) arrays
            Ground truth (metres, 0 = no measurement); occluded here with ``protocol``.
        y : None
            Ignored.
        groups : sequence of str, optional
            The drive of each frame; required unless ``X`` is a dataset whose frames
            carry drive ids (e.g. :class:`~inpaintenv.data.KittiDepth`).

        Returns
        -------
        self

        Raises
        ------
        InvalidInputError
            Without drive ids, when a calibration drive is one the base was trained on
            (its ``training_drives_``), or when no hole pixel has ground truth.
        """
        self._check_params()
        signals = tuple(self.signals)
        check_condition(self.condition, self.condition_edges)
        if hasattr(self.estimator, "fit"):  # an sklearn estimator must be fitted; a bare predictor is taken as is
            check_is_fitted(self.estimator)
        dataset = grouped(X, groups)
        drives = sorted({str(g) for g in dataset.groups})
        self._refuse_seen(self.estimator, drives, "the base estimator")
        second = self._second_fill(self.spread_method) if "spread" in signals else None
        F, r, frame = self._residuals(self.estimator, dataset, signals, second)
        return self._calibrate(F, r, frame, dataset, drives, signals)

    def fit_out_of_fold(self, folds: Sequence[tuple[Any, Any]]) -> ConformalIntervalInpainter:
        """Calibrate ``estimator`` on out-of-fold residuals of models of its recipe (cross-fitting).

        For a model trained on every drive there is, such as a shipped release: each ``(model, X)``
        pair is a model trained *without* ``X``'s drives (a fold model of the same recipe) and
        frames of those drives; the scale and the quantiles are fitted on the pooled residuals of
        each fold model on its own left-out drives, then used around ``estimator``. This is the
        "CV" estimate of cross-conformal prediction: it assumes ``estimator``'s errors on new drives
        are no larger than its fold models' (trained on less); ``calibration_["out_of_fold"]`` records it.

        Parameters
        ----------
        folds : sequence of (fitted model, dataset)
            Each model of ``estimator``'s class, each dataset of whole drives the model
            never saw (checked against its ``training_drives_``), no drive of one input kind
            in two folds (a fill that saw no drive pools densities: one ``(fill, dataset)`` per kind).

        Returns
        -------
        self

        Raises
        ------
        InvalidInputError
            For no folds, a model of another class, a drive a fold model saw or a drive in
            two folds.
        """
        self._check_params()
        signals = tuple(self.signals)
        check_condition(self.condition, self.condition_edges)
        if hasattr(self.estimator, "fit"):
            check_is_fitted(self.estimator)
        if isinstance(folds, (str, bytes)) or not isinstance(folds, Sequence) or not folds:
            raise InvalidInputError("folds must be a non-empty sequence of (fold model, dataset) pairs")
        second = self._second_fill(self.spread_method) if "spread" in signals else None
        feats, resid, frames, records, taken = [], [], [], [], {}
        for k, fold in enumerate(folds):
            if not (isinstance(fold, tuple) and len(fold) == 2):
                raise InvalidInputError(f"folds[{k}] must be a (fold model, dataset) pair, got {type(fold).__name__}")
            model, X = fold
            if type(model) is not type(self.estimator):
                raise InvalidInputError(f"folds[{k}]: the fold model is a {type(model).__name__}, the estimator a "
                                        f"{type(self.estimator).__name__}: fold models must follow its recipe")
            dataset = grouped(X, None)
            drives, kind = sorted({str(g) for g in dataset.groups}), getattr(dataset, "input_kind", "map")
            self._refuse_seen(model, drives, f"folds[{k}]: the fold model")
            twice = sorted(set(drives) & {d for d, i in taken if i == kind})  # once per input kind (density)
            if twice:
                raise InvalidInputError(f"folds[{k}]: drives {twice} are in folds[{taken[twice[0], kind]}] too "
                                        f"(input {kind!r}); each drive calibrates once per input kind")
            taken.update({(d, kind): k for d in drives})
            F, r, frame = self._residuals(model, dataset, signals, second)
            feats.append(F)
            resid.append(r)
            # Frame numbers stay distinct across folds: they only group pixels for the weights.
            frames.append(frame + sum(rec["n_frames"] for rec in records))
            records.append({"drives": drives, "n_frames": len(dataset), "n_pixels": int(r.size),
                            "training_drives": sorted(str(d) for d in getattr(model, "training_drives_", None) or ()),
                            **({"input_kind": kind} if input_kind(kind).separate else {})})  # maps' as they were
        self._calibrate(np.concatenate(feats), np.concatenate(resid), np.concatenate(frames), None,
                        sorted({d for d, _ in taken}), signals, n_frames=sum(rec["n_frames"] for rec in records))
        if kinds := list(dict.fromkeys(rec["input_kind"] for rec in records if "input_kind" in rec)):
            self.calibration_["input_kind"] = "+".join(kinds)  # densities pooled: "scan-rings32-v1+..."
        self.calibration_["out_of_fold"] = records
        return self

    @staticmethod
    def _refuse_seen(model: Any, drives: Sequence[str], who: str) -> None:
        seen = sorted(set(drives) & {str(d) for d in getattr(model, "training_drives_", None) or ()})
        if seen:
            raise InvalidInputError(f"{who} was trained on calibration drives {seen}: calibrate on drives it never "
                                    "saw, or the intervals will be too narrow on new drives")

    def _residuals(self, model: Any, dataset: DepthDataset, signals: tuple[str, ...],
                   second: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The signals (the condition's last), absolute residuals and frame number of ``model``'s every scored pixel."""
        return scored_residuals(model, dataset, with_condition(signals, self.condition), second, self.protocol, self.seed)

    def _calibrate(self, F: np.ndarray, r: np.ndarray, frame: np.ndarray, dataset: DepthDataset | None,
                   drives: list[str], signals: tuple[str, ...], n_frames: int | None = None) -> ConformalIntervalInpainter:
        """Fit the scale on ``(F, r)`` and keep the normalised residuals' (weighted) quantiles."""
        full, F = F, F[:, :1 + len(signals)]  # the condition's own signal, if any, last
        if "spread" in signals and np.ptp(F[:, 1 + signals.index("spread")]) == 0:
            raise InvalidInputError(f"spread is the same at every calibration pixel: spread_method="
                                    f"{self.spread_method!r} fills as the base does; choose another (e.g. 'nearest') "
                                    "or leave 'spread' out of signals")
        self.coef_ = balanced_scale(F, r, frame, signals, int(self.seed), self.max_fit_pixels, self.weighting,
                                    float(self.coverage))
        normed = r / self._scale_from(F)
        self.n_calibration_pixels_ = int(r.size)
        self.residual_quantiles_, self.quantile_ = residual_quantiles(normed, frame, self.weighting,
                                                                      float(self.coverage))
        edges = check_condition(self.condition, self.condition_edges)
        self.condition_ = None if edges is None else fit_condition(
            self.condition, edges, with_condition(signals, self.condition), full, normed, frame, self.weighting,
            float(self.coverage))
        self.calibration_ = {
            "drives": drives, "n_frames": len(dataset) if dataset is not None else int(n_frames or 0),
            "n_pixels": int(r.size), "coverage": float(self.coverage),
            "protocol": self.protocol, "seed": int(self.seed), "base": type(self.estimator).__name__,
            "signals": list(signals), "spread_method": self.spread_method if "spread" in signals else None,
            "weighting": self.weighting,
        }
        kind = getattr(dataset, "input_kind", "map")
        if input_kind(kind).separate:  # maps' records stay as they were
            self.calibration_["input_kind"] = kind
        return self

    _exact_quantile = staticmethod(exact_quantile)  # split-conformal quantile of sorted normalised residuals

    def _scale_from(self, F: np.ndarray) -> np.ndarray:
        """The calibrated scale (metres) of each row of the design matrix ``F``."""
        return scale_from(self.coef_, F)

    def quantile_at(self, coverage: float | None = None) -> float:
        """The conformal quantile ``q`` of ``coverage`` (the calibrated one by default).

        Exact at the calibrated coverage; otherwise read from the stored quantiles at the
        next level at or above ``ceil((n + 1) c) / n`` (conservative).
        """
        check_is_fitted(self)
        c = float(self.coverage) if coverage is None else check_coverage(coverage)
        if math.isclose(c, self.calibration_["coverage"]):
            return self.quantile_
        # The pixel weighting's finite-sample correction; the frame weighting has none.
        return stored_quantile(self.residual_quantiles_, self.n_calibration_pixels_, c,
                               self.calibration_.get("weighting", "pixel"))

    def _half(self, x: np.ndarray, pred: np.ndarray, hole: np.ndarray, coverage: float | None) -> np.ndarray:
        """Per-pixel half-width (metres) at ``coverage``: the scale times its bin's ``q`` (the pooled one unconditioned)."""
        scale, cells = self._scale(x, pred, hole)
        q = self.quantile_at(coverage)
        cond = getattr(self, "condition_", None)
        if cond is None:
            return scale * q
        c = float(self.coverage) if coverage is None else check_coverage(coverage)
        return scale * cell_quantiles(cond, q, c, math.isclose(c, self.calibration_["coverage"]),
                                      self.calibration_.get("weighting", "pixel"))[cells]

    # -- prediction --------------------------------------------------------------
    def _scale(self, x: np.ndarray, pred: np.ndarray, hole: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """Per-pixel scale (metres), 0 outside the hole, and bin (None unconditioned); ``x``, ``pred``, ``hole`` are (N, H, W).

        The last batch's is kept (keyed by a digest of ``x`` and ``pred``): intervals of several
        coverages of one batch (a reliability diagram) compute it once.
        """
        key = hashlib.blake2b(np.ascontiguousarray(x).tobytes(), digest_size=16)
        key.update(np.ascontiguousarray(pred, dtype=np.float32).tobytes())
        digest = (x.shape, key.digest(), id(self.coef_))
        last = self.__dict__.get("_last_scale")
        if last is not None and last[0] == digest:
            return last[1]
        out = self._compute_scale(x, pred, hole)
        for arr in out[:1] if out[1] is None else out:
            arr.flags.writeable = False  # shared by the calls of one batch: never written
        self.__dict__["_last_scale"] = (digest, out)
        return out

    def __getstate__(self) -> dict[str, Any]:
        state = dict(self.__dict__)
        state.pop("_last_scale", None)  # a cache: never pickled (or sent to a worker) with the estimator
        return state

    def _compute_scale(self, x: np.ndarray, pred: np.ndarray, hole: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        signals = tuple(self.calibration_["signals"])
        other = None
        if "spread" in signals:
            # The calibrated fill, whatever spread_method says now.
            other = np.asarray(self._second_fill(self.calibration_["spread_method"]).predict(x), dtype=np.float64)
        out = np.zeros(pred.shape, dtype=np.float64)
        cond = getattr(self, "condition_", None)
        cells = None if cond is None else np.zeros(pred.shape, dtype=np.int64)
        every = with_condition(signals, None if cond is None else cond["variable"])
        for k in range(len(pred)):
            if hole[k].any():
                F = features(every, pred[k], hole[k], None if other is None else other[k])
                out[k][hole[k]] = self._scale_from(F[:, :1 + len(signals)])
                if cells is not None:
                    cells[k][hole[k]] = cell_of(cond, every, F)
        return out, cells

    def _batch(self, X: Any) -> tuple[np.ndarray, bool]:
        x = check_inpaint_input(X, require_hole=False)
        return (x[None], True) if x.ndim == 2 else (x, False)

    def predict(self, X: Any, return_std: bool = False) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """The base's prediction, unchanged; with ``return_std`` also a per-pixel std.

        Parameters
        ----------
        X : array-like
            ``(H, W)`` or ``(N, H, W)`` metres, NaN = fill, 0 = no measurement.
        return_std : bool, default=False
            Also return ``std``.

        Returns
        -------
        pred : numpy.ndarray
            ``estimator.predict(X)`` exactly.
        std : numpy.ndarray, only with ``return_std``
            float32 metres, ``scale · q_c / z_c``: the conformal half-width at the
            calibrated coverage ``c`` (``calibration_["coverage"]``) divided by the normal quantile ``z_c`` (1.645 for
            0.9), so that ``pred ± z_c · std`` is the calibrated interval (what
            :func:`inpaintenv.metrics.interval_from_std` builds). It is a
            "normal-equivalent" std: the residuals are not assumed normal, and
            ``pred ± z · std`` at another coverage is *not* calibrated (use
            :meth:`predict_interval`). 0 outside the hole (NaN pixels of ``X``).
        """
        check_is_fitted(self)
        pred = self.estimator.predict(X)
        if not return_std:
            return pred
        x, single = self._batch(X)
        p = checked_prediction(pred, x, "predict(return_std=True)", X, self.estimator)
        half = self._half(x, p, np.isnan(x), self.calibration_["coverage"])
        # The calibrated coverage, which quantile_ belongs to (a later set_params does not change it).
        std = (half / normal_quantile(self.calibration_["coverage"])).astype(np.float32)
        return pred, std[0] if single else std

    def predict_interval(self, X: Any, coverage: float | None = None, *,
                         prediction: Any = None) -> tuple[np.ndarray, np.ndarray]:
        """Per-pixel ``(low, high)`` of nominal ``coverage`` around the base's prediction.

        Parameters
        ----------
        X : array-like
            ``(H, W)`` or ``(N, H, W)`` metres, NaN = fill.
        coverage : float, optional
            In (0, 1); the calibrated ``coverage`` by default. Any coverage works (the
            calibration keeps the residual quantiles); see :meth:`quantile_at`.
        prediction : array-like, optional
            ``predict(X)``'s result when the caller has it already (``evaluate`` and
            ``inpaintenv fill`` pass theirs): the base is then not run again.

        Returns
        -------
        low, high : numpy.ndarray
            float32 metres of ``X``'s shape: ``low = max(pred - q·scale, 0) <= pred <=
            high = pred + q·scale``, finite with ``high - low > 0`` at every NaN pixel of
            ``X``, and ``low = high = pred`` elsewhere (measured pixels are given, not filled).
        """
        check_is_fitted(self)
        self.quantile_at(coverage)  # a coverage too fine for the calibration is refused before the base runs
        x, single = self._batch(X)
        if prediction is None:
            pred = checked_prediction(self.estimator.predict(x), x, "predict_interval", X, self.estimator)
        else:
            pred = checked_prediction(prediction, x, "predict_interval", X)
        hole = np.isnan(x)
        # Only the hole's pixels have a width: the rest of the frame is pred itself.
        p = pred[hole]
        # A width below float32's resolution at pred would round to an empty interval.
        half = np.maximum(self._half(x, pred, hole, coverage)[hole], 4.0 * np.spacing(np.abs(p)))
        low, high = pred.copy(), pred.copy()
        # float32 rounding never excludes pred
        low[hole] = np.minimum(np.maximum(p - half, 0.0).astype(np.float32), p)
        high[hole] = np.maximum((p + half).astype(np.float32), p)
        return (low[0], high[0]) if single else (low, high)
