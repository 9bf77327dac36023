"""Classical candidate fills used as input priors by learned inpainters (no torch).

A learned model that starts from strong classical fills only has to learn where each
one is right (a per-pixel blend) and a small correction, which a CPU-sized network
can do in minutes; learning depth from scratch cannot (issue 8). The candidates reuse
the classical estimators' fill functions and are computed on the *whole* frame, so a
row-wise fill stays exact when a network later sees a crop of rows.

>>> import numpy as np
>>> from estimators.priors import prior_features, CANDIDATES
>>> x = np.full((4, 6), 10.0, dtype=np.float32); x[1:3, 2:4] = np.nan
>>> prior_features(x).shape == (3 + len(CANDIDATES), 4, 6)
True
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from inpaintenv.conventions import check_depth

from .classical.harmonic import harmonic_fill
from .classical.scanline import scanline_fill

__all__ = ["BASE_CHANNELS", "CANDIDATES", "candidate_fills", "prior_features"]

#: Candidate fills, in channel order: row-wise linear interpolation of depth, of inverse
#: depth, column-wise linear interpolation of depth, harmonic (Laplace) interpolation.
CANDIDATES: tuple[str, ...] = ("scanline", "scanline-inverse", "vertical", "harmonic")
#: Channels before the candidates in :func:`prior_features`.
BASE_CHANNELS: tuple[str, ...] = ("depth", "hole", "valid")


def _inverse_scanline(values: np.ndarray, known: np.ndarray) -> np.ndarray:
    inv = np.divide(1.0, values, out=np.zeros(values.shape), where=known)
    filled = scanline_fill(inv, known)
    return np.divide(1.0, filled, out=np.zeros(values.shape), where=filled > 0)


_FILLS = {
    "scanline": lambda v, k: scanline_fill(v, k),
    "scanline-inverse": _inverse_scanline,
    "vertical": lambda v, k: scanline_fill(v.T, k.T).T,
    "harmonic": harmonic_fill,
}


def _check_names(names: Sequence[str]) -> tuple[str, ...]:
    names = tuple(names)
    unknown = [n for n in names if n not in _FILLS]
    if not names or unknown:
        raise ValueError(f"candidates must be a non-empty subset of {CANDIDATES}, got {names!r}")
    return names


def candidate_fills(x: np.ndarray, names: Sequence[str] = CANDIDATES) -> np.ndarray:
    """Classical fills of one corrupted frame.

    Parameters
    ----------
    x : numpy.ndarray
        ``(H, W)`` metres; NaN = hole to fill, 0 = no measurement (both unknown).
    names : sequence of str
        Which fills, from :data:`CANDIDATES`.

    Returns
    -------
    numpy.ndarray
        ``(len(names), H, W)`` float32 metres, equal to ``x`` where it is measured
        (zeros everywhere if nothing is measured).
    """
    names = _check_names(names)
    x = check_depth(x, name="x", allow_nan=True, ndim=(2,))
    known = x > 0
    values = np.where(known, x, 0.0)
    return np.stack([_FILLS[n](values, known) for n in names]).astype(np.float32)


def prior_features(x: np.ndarray, names: Sequence[str] = CANDIDATES) -> np.ndarray:
    """Network input of one frame: observed depth, hole and validity masks, candidates.

    Parameters
    ----------
    x : numpy.ndarray
        ``(H, W)`` metres; NaN = hole, 0 = no measurement.
    names : sequence of str
        Candidate fills, from :data:`CANDIDATES`.

    Returns
    -------
    numpy.ndarray
        ``(3 + len(names), H, W)`` float32: depth (0 where unknown), hole (1/0),
        valid (1 where measured), then the candidate fills in metres.
    """
    fills = candidate_fills(x, names)
    hole = np.isnan(x)
    depth = np.where(x > 0, x, 0.0)
    base = np.stack([depth, hole, depth > 0]).astype(np.float32)
    return np.concatenate([base, fills])
