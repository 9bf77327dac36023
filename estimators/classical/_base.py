"""Shared behaviour of the classical inpainters: the shared parameters and parallel frames.

A classical method only implements :meth:`ClassicalInpainter._fill_frame` for one
``(H, W)`` frame; this module runs it over a batch (in parallel with joblib when
``n_jobs`` asks for it) and keeps OpenCV from oversubscribing the cores meanwhile.
"""

from __future__ import annotations

import threading
from abc import abstractmethod
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import cv2
import numpy as np
from joblib import Parallel, delayed, effective_n_jobs

from .._constraints import Bool, Check, ConstrainedParams, Constraint
from ..base import BaseInpainter, check_n_jobs

__all__ = ["FILL_MODES", "ClassicalInpainter", "in_inverse_depth", "unknown_mask"]

#: ``"invalid"``: every pixel without a measurement (NaN or 0) is unknown (sound);
#: ``"hole"``: only NaN is unknown, unmeasured pixels count as depth 0 (the study).
FILL_MODES = ("invalid", "hole")
#: joblib backend for frames of a batch. OpenCV and the large NumPy operations release
#: the GIL, so threads avoid copying frames between processes (as fast as or faster
#: than loky for 13 of 14 configurations in perf/bench_classical.py). Passed to
#: joblib as a soft hint (``prefer="threads"``), so a caller's
#: ``joblib.parallel_config(backend=...)`` (loky, dask, ray) still chooses the backend.
PARALLEL_BACKEND = "threading"

_PREFER = {"threading": "threads", "loky": "processes"}

_cv2_threads_lock = threading.Lock()


@contextmanager
def opencv_threads(n: int) -> Iterator[None]:
    """Set ``cv2.setNumThreads(n)`` for the duration of the block, then restore it."""
    with _cv2_threads_lock:
        previous = cv2.getNumThreads()
        cv2.setNumThreads(n)
    try:
        yield
    finally:
        with _cv2_threads_lock:
            cv2.setNumThreads(previous)


def in_inverse_depth(
    fill: Callable[..., np.ndarray], values: np.ndarray, known: np.ndarray, *args: Any
) -> np.ndarray:
    """Run ``fill(values, known, *args)`` on inverse depth and return depth.

    Inverse depth is affine in image coordinates on any plane (road, walls, the sides
    of cars), so interpolating it instead of depth reproduces planes seen in
    perspective. Interpolants that stay between their positive boundary values give
    positive inverse depth wherever something is known; pixels left at 0 (nothing
    known) stay 0.

    Parameters
    ----------
    fill : callable
        ``fill(values, known, *args) -> filled`` on ``(H, W)`` arrays.
    values : numpy.ndarray
        ``(H, W)`` depth in metres, read where ``known``.
    known : numpy.ndarray
        ``(H, W)`` bool.

    Returns
    -------
    numpy.ndarray
        ``(H, W)`` float32 depth, ``values`` where ``known``.
    """
    inv = np.divide(1.0, values, out=np.zeros(values.shape), where=known)
    filled = fill(inv, known, *args)
    depth = np.divide(1.0, filled, out=np.zeros(values.shape), where=filled > 0)
    # 1 / (1 / d) is not always d in floating point: measured pixels are returned exactly.
    return np.where(known, values, depth).astype(np.float32)


def unknown_mask(x: np.ndarray, fill: str = "invalid") -> np.ndarray:
    """Pixels a method must estimate: NaN and 0 (``"invalid"``) or NaN only (``"hole"``)."""
    if fill == "hole":
        return np.isnan(x)
    return ~(x > 0)  # NaN > 0 is False, so NaN counts as unknown


class ClassicalInpainter(ConstrainedParams, BaseInpainter):
    """Base of the classical (non-learned, stateless) inpainters.

    Subclasses store their keyword-only parameters, declare them in
    ``_parameter_constraints`` (``{**ClassicalInpainter._parameter_constraints, ...}``,
    checked by :class:`~estimators._constraints.ConstrainedParams` in ``fit`` and
    ``predict``) and implement :meth:`_fill_frame`. They predict without ``fit``; ``fit``
    only validates parameters and one frame.
    """

    _stateless = True

    _parameter_constraints: dict[str, list[Constraint | None]] = {
        "keep_observed": [Bool()],
        "n_jobs": [Check(check_n_jobs), None],  # joblib's meaning: -1 = all cores, 0 refused
    }

    # -- the work ------------------------------------------------------------------
    def _fit(self, dataset: Any) -> None:
        self._check_params()
        super()._fit(dataset)

    def _predict_batch(self, X: np.ndarray) -> np.ndarray:
        self._check_params_once()
        n_workers = min(effective_n_jobs(self.n_jobs), len(X))
        if n_workers <= 1:
            frames = [self._fill_frame(X[i]) for i in range(len(X))]
        else:
            # One OpenCV thread per worker: n_workers × OpenCV's own pool would
            # oversubscribe the cores.
            with opencv_threads(1):
                frames = Parallel(n_jobs=n_workers, prefer=_PREFER[PARALLEL_BACKEND])(
                    delayed(self._fill_frame)(X[i]) for i in range(len(X))
                )
        return np.stack(frames).astype(np.float32, copy=False)

    @abstractmethod
    def _fill_frame(self, x: np.ndarray) -> np.ndarray:
        """Fill one validated ``(H, W)`` float32 frame (NaN = fill, 0 = no data).

        ``x`` may be read-only and must not be modified. Return ``(H, W)`` depth that is
        finite everywhere; observed pixels are composited back by ``predict``.
        """
