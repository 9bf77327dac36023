"""The shared estimator API: validation, the NaN/0 convention, keep_observed, score.

Every inpainter is a scikit-learn estimator:

* ``fit(X)`` takes ground-truth depth maps (an ``inpaintenv`` dataset, a sequence of
  ``(H, W)`` arrays, or an ``(N, H, W)`` array) and returns ``self``;
* ``predict(X)`` takes the corrupted input -- metres, NaN = fill, 0 = no measurement --
  as ``(H, W)`` or ``(N, H, W)`` and returns float32 metres of the same shape with every
  pixel predicted;
* ``score(X, y=None)`` returns minus the hole RMSE (greater is better).
"""

from __future__ import annotations

import numbers
import re
from abc import abstractmethod
from collections.abc import Iterator
from typing import Any

import numpy as np
from sklearn.base import BaseEstimator
from sklearn.utils.validation import check_is_fitted

from inpaintenv.conventions import DEFAULT_MAX_DEPTH, check_depth, reconstruction_problem
from inpaintenv.data.base import DepthDataset, as_dataset
from inpaintenv.data.inputs import input_kind, method_input
from inpaintenv.masks import get_protocol
from inpaintenv.metrics import aggregate, frame_metrics
from inpaintenv.exceptions import InvalidInputError, InvalidTypeError, MethodOutputError

__all__ = [
    "BaseInpainter", "check_inpaint_input", "check_n_jobs", "check_random_state", "iter_scoring_batches",
    "resolve_seed", "training_drives",
]

#: Protocol and seed that ``score(X)`` uses to corrupt ground truth when no ``y`` is given.
SCORE_PROTOCOL = "rect-v1"
SCORE_SEED = 0
#: Frames predicted per call when scoring a dataset (bounds memory on large sets).
SCORE_CHUNK = 8


def check_inpaint_input(X: Any, *, require_hole: bool = True) -> np.ndarray:
    """Validate a method input (NaN = fill, 0 = no measurement) as float32.

    Parameters
    ----------
    X : array-like
        ``(H, W)`` or ``(N, H, W)`` depth in metres.
    require_hole : bool
        Raise if there is no NaN at all (nothing to inpaint usually means the caller
        zeroed the holes instead of marking them NaN).

    Returns
    -------
    numpy.ndarray
        C-contiguous float32 array (so the input's memory layout never changes a
        result); the input itself when it already is one (never modified).
    """
    arr = check_depth(X, name="X", allow_nan=True)
    if require_hole and not np.isnan(arr).any():
        raise InvalidInputError(
            "X has no NaN: mark the pixels to fill with NaN (0 means 'no measurement', "
            "not 'hole')"
        )
    return arr


def check_random_state(value: Any, name: str = "random_state") -> None:
    """Raise a clear ValueError unless ``value`` is a valid ``random_state``.

    Accepted, as scikit-learn's estimators accept them: None, a non-negative integer, a
    ``numpy.random.RandomState`` or a ``numpy.random.Generator``.
    """
    if value is None or isinstance(value, (np.random.RandomState, np.random.Generator)):
        return
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral) or value < 0:
        raise InvalidInputError(
            f"{name} must be None, a non-negative int, a numpy RandomState or a numpy Generator, got {value!r}"
        )


def check_n_jobs(value: Any, name: str = "n_jobs") -> None:
    """Raise a clear ValueError unless ``value`` is a valid ``n_jobs`` (joblib's meaning).

    Accepted: None (one job) or a non-zero integer (``-1`` = all cores, ``-2`` = all but
    one, ...); a bool is no integer here.
    """
    if value is not None and (
        isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral) or value == 0
    ):
        raise InvalidInputError(f"{name} must be None or a non-zero integer (-1 = all cores), got {value!r}")


def resolve_seed(value: Any, name: str = "random_state") -> int:
    """The integer seed a fit uses for ``random_state`` (see :func:`check_random_state`).

    An int is the seed itself (the same fit every time); None draws a fresh seed; a
    ``RandomState`` or ``Generator`` gives the next number of its stream (and so advances
    it: two fits with one instance differ, as in scikit-learn).
    """
    check_random_state(value, name)
    if value is None:
        return int(np.random.SeedSequence().generate_state(1)[0])
    if isinstance(value, np.random.RandomState):
        return int(value.randint(0, 2**31 - 1))
    if isinstance(value, np.random.Generator):
        return int(value.integers(0, 2**31 - 1))
    return int(value)


def iter_scoring_batches(
    X: Any, y: Any = None, *, protocol: str = SCORE_PROTOCOL, seed: int = SCORE_SEED,
    chunk: int = SCORE_CHUNK,
) -> Iterator[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Yield ``(corrupted, ground_truth, scored)`` batches for scoring.

    With ``y``, ``X`` is the corrupted input and ``y`` the ground truth, and every NaN
    pixel of ``X`` is scored. Without ``y``, ``X`` is a dataset and frame ``i``'s hole is
    ``protocol``'s mask for ``(seed, i)``, cut out of the dataset's measured input
    (:func:`inpaintenv.data.method_input`): for a map the input is the ground truth and
    the hole is scored; for a single scan (a dataset whose input kind is ``separate``) every pixel left to
    fill is scored (the unmeasured pixels, the hole included), as ``evaluate``'s
    ``unmeasured`` set.
    """
    if y is not None:
        x = check_inpaint_input(X)
        gt = check_depth(y, name="y")
        if x.shape != gt.shape:
            raise InvalidInputError(f"X has shape {x.shape} but y has {gt.shape}")
        if x.ndim == 2:
            x, gt = x[None], gt[None]
        yield x, gt, np.isnan(x)
        return
    dataset = as_dataset(X)
    proto = get_protocol(protocol)
    kind = input_kind(getattr(dataset, "input_kind", "map"))
    for start in range(0, len(dataset), chunk):
        idx = range(start, min(start + chunk, len(dataset)))
        inputs, gt = dataset.load_pairs(idx)
        hole = proto.masks(dataset.frame_shape, seed, idx)
        x = method_input(inputs, hole, kind)
        yield x, gt, kind.scored(x, hole)


#: Drive ids that :class:`~inpaintenv.data.ArrayDataset` makes up for frames without one.
_UNNAMED_GROUP = re.compile(r"frame\d+")


def training_drives(dataset: DepthDataset) -> list[str] | None:
    """The sorted drive ids of ``dataset``'s frames, or None when its frames carry none.

    Plain arrays get made-up ids (``frame0``, ``frame1``, ...) that would match any other
    array's: they are not recorded.
    """
    drives = sorted({str(g) for g in np.asarray(dataset.groups).tolist()})
    return None if all(_UNNAMED_GROUP.fullmatch(d) for d in drives) else drives


class BaseInpainter(BaseEstimator):
    """Base class of all inpainters (do not instantiate).

    Subclasses take keyword-only parameters in ``__init__`` and only store them,
    implement :meth:`_predict_batch`, and override :meth:`_fit` when they learn.
    Stateless (classical) subclasses set ``_stateless = True``: they can predict
    without ``fit``.
    """

    _stateless: bool = False

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.input_tags.two_d_array = False
        tags.input_tags.three_d_array = True
        tags.input_tags.allow_nan = True
        tags.input_tags.positive_only = True
        tags.target_tags.required = False
        tags.requires_fit = not self._stateless
        tags.non_deterministic = False
        return tags

    def __sklearn_is_fitted__(self) -> bool:
        return self._stateless or getattr(self, "is_fitted_", False)

    # -- fitting -----------------------------------------------------------------
    def fit(self, X: Any, y: Any = None) -> BaseInpainter:
        """Fit on ground-truth depth maps.

        Parameters
        ----------
        X : DepthDataset, sequence of (H, W) arrays, or (N, H, W) array
            Ground truth in metres (0 = no measurement).
        y : None
            Ignored; present for scikit-learn compatibility.

        Returns
        -------
        self
        """
        dataset = as_dataset(X)
        if len(dataset) == 0:
            raise InvalidInputError("cannot fit on an empty dataset")
        self._fit(dataset)
        if not self._stateless:
            # Saved with the model: a benchmark marks the drives a model was trained on.
            self.training_drives_ = training_drives(dataset)
        self.is_fitted_ = True
        return self

    def _fit(self, dataset: DepthDataset) -> None:
        """Learn from ``dataset``; classical methods learn nothing.

        Learned estimators also get ``training_drives_`` from :meth:`fit` (see
        :func:`training_drives`)."""
        # Touch one frame so bad data fails at fit time, not later.
        check_depth(dataset[0], name="X[0]")

    # -- prediction --------------------------------------------------------------
    def predict(self, X: Any) -> np.ndarray:
        """Fill the NaN pixels of one depth map or a batch.

        Parameters
        ----------
        X : array-like
            ``(H, W)`` or ``(N, H, W)`` metres; NaN = fill, 0 = no measurement.
            Never modified (read-only / memory-mapped input is fine).

        Returns
        -------
        numpy.ndarray
            float32 depth of the same shape, finite and non-negative everywhere. With
            ``keep_observed=True`` the measured (positive) input pixels are returned
            unchanged.
        """
        check_is_fitted(self)
        x = check_inpaint_input(X)
        batch = x[None] if x.ndim == 2 else x
        raw = np.asarray(self._predict_batch(batch))
        if raw.dtype.kind not in "fiu":  # a complex output would lose its imaginary part in the cast
            raise InvalidTypeError(f"{type(self).__name__} produced depth of dtype {raw.dtype}; depth is real metres")
        out = raw.astype(np.float32, copy=False)
        if out.shape != batch.shape:
            raise RuntimeError(
                f"{type(self).__name__} returned shape {out.shape} for input {batch.shape}"
            )
        if not np.isfinite(out).all():
            raise RuntimeError(f"{type(self).__name__} produced NaN or inf depth")
        out = np.maximum(out, 0.0)
        if getattr(self, "keep_observed", True):
            observed = batch > 0  # NaN > 0 is False
            out = np.where(observed, batch, out)
        return out[0] if x.ndim == 2 else out

    @abstractmethod
    def _predict_batch(self, X: np.ndarray) -> np.ndarray:
        """Predict a validated ``(N, H, W)`` float32 batch (NaN = fill); must not modify X."""
        # BaseEstimator is no ABC, so the decorator only documents: say it at the call.
        raise NotImplementedError(f"{type(self).__name__} must implement _predict_batch")

    # -- scoring -----------------------------------------------------------------
    def score_frames(
        self, X: Any, y: Any = None, *, protocol: str = SCORE_PROTOCOL, seed: int = SCORE_SEED,
        max_depth: float = DEFAULT_MAX_DEPTH,
    ) -> dict[str, np.ndarray]:
        """Per-frame metrics (see :func:`inpaintenv.metrics.frame_metrics`).

        Parameters are as in :meth:`score`; ``protocol`` and ``seed`` only apply when
        ``y`` is None.

        Raises
        ------
        MethodOutputError
            A prediction that :func:`inpaintenv.evaluate.evaluate` and the env refuse: a
            pixel outside ``[0, DEPTH_LIMIT]`` anywhere in the frame, with or without ground truth.
        """
        parts: list[dict[str, np.ndarray]] = []
        for x, gt, hole in iter_scoring_batches(X, y, protocol=protocol, seed=seed):
            # predict fills every pixel by contract, so a 0 m here is the method's estimate
            # (a regression clipped at 0, the study's hole-only fills), scored as 0 m, never
            # "unfilled": model selection must not stop on a poor candidate.
            pred = self.predict(x)
            # The rule evaluate and the env apply to every reconstruction, at every pixel.
            problem = reconstruction_problem(pred)
            if problem is not None:
                raise MethodOutputError(f"method {type(self).__name__!r}: output {problem}")
            parts.append(frame_metrics(pred, gt, hole, max_depth=max_depth, unfilled="zero"))
        return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}

    def score(self, X: Any, y: Any = None) -> float:
        """Minus the mean per-frame hole RMSE in metres (greater is better).

        A prediction of 0 m is scored as 0 m (``predict`` fills every pixel, so it is
        an estimate, not an unfilled pixel; see :func:`inpaintenv.metrics.frame_metrics`).

        Parameters
        ----------
        X : array-like or DepthDataset
            With ``y``: the corrupted input (NaN = fill). Without ``y``: ground truth,
            corrupted here with the ``rect-v1`` protocol and seed 0 (frame ``i`` gets the
            mask of index ``i``), so every estimator is scored on the same holes.
        y : array-like, optional
            Ground truth matching ``X``.

        Returns
        -------
        float
        """
        table = aggregate(self.score_frames(X, y))
        if np.isnan(table["hole_rmse"]):
            raise InvalidInputError("no frame has ground truth inside its holes; nothing to score")
        return -table["hole_rmse"]
