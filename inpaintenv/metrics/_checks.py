"""The checks of a prediction scored against ground truth, shared by the metrics modules."""

from __future__ import annotations

import numpy as np

from ..conventions import as_depth_array, check_depth, check_mask, reconstruction_problem
from ..exceptions import InvalidInputError

__all__: list[str] = []


def _check_inputs(pred: np.ndarray, gt: np.ndarray, hole: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(pred, gt, hole)`` as arrays after checking ground truth, shapes, dtype and mask."""
    gt = check_depth(gt, name="ground truth")
    return _check_pred(pred, gt.shape), gt, check_mask(hole, gt.shape)


def _check_pred(pred: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """``pred`` as an array after checking its dtype (:func:`~inpaintenv.conventions.as_depth_array`) and shape."""
    pred_arr = as_depth_array(pred, "prediction")
    if pred_arr.shape != shape:
        raise InvalidInputError(f"prediction has shape {pred_arr.shape}, ground truth {shape}")
    return pred_arr


def _checked_scored(scored_pred: np.ndarray) -> np.ndarray:
    """The prediction at scored pixels as float64, refused as the env refuses an action (``reconstruction_problem``)."""
    problem = reconstruction_problem(scored_pred)
    if problem is not None:
        raise InvalidInputError(f"prediction at pixels with ground truth {problem}")
    return scored_pred.astype(np.float64)
