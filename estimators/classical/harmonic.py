"""Harmonic (Laplace) fill: unknown depth solves Laplace's equation, known depth fixed."""

from __future__ import annotations

import cv2
import numpy as np

from .._constraints import Bool, Integer
from ._base import ClassicalInpainter, in_inverse_depth, unknown_mask
from .nearest import nearest_fill

__all__ = ["HarmonicInpainter", "harmonic_fill"]

# Mean of the 4 neighbours: one Jacobi step of the discrete Laplace equation.
_JACOBI_KERNEL = np.array([[0, 0.25, 0], [0.25, 0, 0.25], [0, 0.25, 0]], dtype=np.float32)
#: Below this size the coarsest level is initialised by nearest-valid fill.
_COARSEST = 8


def _downsample(values: np.ndarray, known: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Halve the resolution: mean of the known pixels of each 2×2 block."""
    h, w = values.shape
    ph, pw = h % 2, w % 2
    v = np.pad(np.where(known, values, 0.0), ((0, ph), (0, pw)))
    k = np.pad(known, ((0, ph), (0, pw))).astype(np.float32)
    hc, wc = v.shape[0] // 2, v.shape[1] // 2
    vs = v.reshape(hc, 2, wc, 2).sum(axis=(1, 3))
    ks = k.reshape(hc, 2, wc, 2).sum(axis=(1, 3))
    coarse_known = ks > 0
    return np.divide(vs, ks, out=np.zeros_like(vs), where=coarse_known).astype(np.float32), coarse_known


def harmonic_fill(values: np.ndarray, known: np.ndarray, iterations: int = 50) -> np.ndarray:
    """Harmonic interpolation of the unknown pixels, solved coarse to fine.

    Each pyramid level starts from the upsampled solution of the coarser level and runs
    ``iterations`` vectorised Jacobi sweeps, so information crosses large holes in a
    few sweeps per level instead of thousands at full resolution.

    Parameters
    ----------
    values : numpy.ndarray
        ``(H, W)``; only read where ``known``.
    known : numpy.ndarray
        ``(H, W)`` bool: Dirichlet boundary pixels.
    iterations : int
        Jacobi sweeps per level.

    Returns
    -------
    numpy.ndarray
        float32 ``(H, W)``, equal to ``values`` where known; zeros if nothing is known.
    """
    fixed = np.where(known, values, 0.0).astype(np.float32)
    if not known.any() or known.all():
        return fixed
    h, w = values.shape
    if min(h, w) <= _COARSEST:
        current = nearest_fill(fixed, known)
    else:
        coarse = harmonic_fill(*_downsample(fixed, known), iterations=iterations)
        current = cv2.resize(coarse, (2 * coarse.shape[1], 2 * coarse.shape[0]),
                             interpolation=cv2.INTER_LINEAR)[:h, :w]
    # Two buffers swapped in place: no new arrays per sweep (~25 % faster at KITTI size).
    current = np.ascontiguousarray(current, dtype=np.float32)
    avg = np.empty_like(current)
    for _ in range(iterations):
        # Replicated border = zero normal derivative at the image edge.
        cv2.filter2D(current, -1, _JACOBI_KERNEL, dst=avg, borderType=cv2.BORDER_REPLICATE)
        np.copyto(avg, fixed, where=known)
        current, avg = avg, current
    return current


class HarmonicInpainter(ClassicalInpainter):
    """Fill unmeasured pixels with the harmonic (smoothest, membrane) interpolant.

    Unknown depth solves the discrete Laplace equation with the measurements as fixed
    boundary values, solved on an image pyramid (coarse-to-fine initialisation and a
    few Jacobi sweeps per level), so it stays fast on full KITTI frames.

    Parameters
    ----------
    iterations : int, default=50
        Jacobi sweeps per pyramid level (more converge further; 50 was chosen on the
        tuning drive, see docs/baselines.md).
    inverse : bool, default=False
        Interpolate inverse depth instead of depth. A harmonic function with affine
        boundary values is that affine function, and inverse depth is affine in image
        coordinates on any plane, so the inverse fill reproduces planes seen in
        perspective (road, walls) exactly; the depth fill bends them.
    keep_observed : bool, default=True
        Return measured input pixels unchanged.
    n_jobs : int or None, default=None
        Frames processed in parallel (joblib; None = 1, -1 = all cores).
    """

    def __init__(
        self, *, iterations: int = 50, inverse: bool = False, keep_observed: bool = True,
        n_jobs: int | None = None,
    ):
        self.iterations = iterations
        self.inverse = inverse
        self.keep_observed = keep_observed
        self.n_jobs = n_jobs

    _parameter_constraints = {
        **ClassicalInpainter._parameter_constraints,
        "iterations": [Integer(1)],
        "inverse": [Bool()],
    }

    def _fill_frame(self, x: np.ndarray) -> np.ndarray:
        known = ~unknown_mask(x)
        if self.inverse:
            return in_inverse_depth(harmonic_fill, x, known, self.iterations)
        return harmonic_fill(x, known, self.iterations)
