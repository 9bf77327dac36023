"""Where a method's hole error comes from: pooled errors per true-depth bin."""

from __future__ import annotations

import itertools

import numpy as np

from ..exceptions import InvalidInputError
from ._checks import _check_inputs, _checked_scored

__all__ = ["DEPTH_BIN_EDGES", "depth_binned_errors"]

#: Default true-depth bins (metres) of :func:`depth_binned_errors`.
DEPTH_BIN_EDGES = (0.0, 10.0, 20.0, 30.0, 50.0, np.inf)


def depth_binned_errors(
    pred: np.ndarray,
    gt: np.ndarray,
    hole: np.ndarray,
    *,
    edges: tuple[float, ...] = DEPTH_BIN_EDGES,
) -> list[dict[str, float]]:
    """Where a method's hole error comes from: pooled errors per true-depth bin.

    RMSE in metres weighs far pixels heavily; this breaks the squared error inside the
    holes down by the ground-truth depth, pooled over every scored pixel of the batch.

    Parameters
    ----------
    pred, gt, hole : numpy.ndarray
        As for :func:`frame_metrics`, ``(H, W)`` or ``(N, H, W)``.
    edges : tuple of float
        Increasing bin edges in metres; bin ``k`` is ``edges[k] <= gt < edges[k+1]``.

    Returns
    -------
    list of dict
        One row per bin: ``lo``, ``hi``, ``pixels`` (count), ``pixel_share`` and
        ``sse_share`` (of all scored hole pixels / of their summed squared error),
        ``rmse`` and ``bias`` (mean of prediction − truth, m; NaN for an empty bin).

    Raises
    ------
    ValueError
        No hole pixel with ground truth, or edges that are not increasing.

    Examples
    --------
    >>> gt = np.array([[5.0, 60.0]]); hole = np.ones_like(gt, dtype=bool)
    >>> rows = depth_binned_errors(np.array([[5.0, 40.0]]), gt, hole, edges=(0, 50, np.inf))
    >>> [(r["pixels"], r["sse_share"], r["bias"]) for r in rows]
    [(1, 0.0, 0.0), (1, 1.0, -20.0)]
    """
    pred_arr, gt, hole = _check_inputs(pred, gt, hole)
    edges_arr = np.asarray(edges, dtype=np.float64)
    if edges_arr.ndim != 1 or len(edges_arr) < 2 or not (np.diff(edges_arr) > 0).all():
        raise InvalidInputError(f"edges must be at least two increasing values, got {edges!r}")
    scored = hole & (gt > 0)
    if not scored.any():
        raise InvalidInputError("no hole pixel has ground truth: nothing to break down")
    p = _checked_scored(pred_arr[scored])
    g = gt[scored].astype(np.float64)
    err = p - g
    sq = err * err
    total_sse = sq.sum()
    rows = []
    for lo, hi in itertools.pairwise(edges_arr):
        in_bin = (g >= lo) & (g < hi)
        n = int(in_bin.sum())
        rows.append({
            "lo": float(lo), "hi": float(hi), "pixels": n,
            "pixel_share": n / len(g),
            # A perfect prediction has no squared error to share out.
            "sse_share": float(sq[in_bin].sum() / total_sse) if total_sse > 0 else 0.0,
            "rmse": float(np.sqrt(sq[in_bin].mean())) if n else float("nan"),
            "bias": float(err[in_bin].mean()) if n else float("nan"),
        })
    return rows
