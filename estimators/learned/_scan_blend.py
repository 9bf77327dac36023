"""ScanBlendInpainter: a single LiDAR scan filled by a classical mean near its measurements and
a learned blend far from them.

Between a scan's lines (a pixel or a few from a measurement) the per-pixel mean of
``harmonic`` and ``ipbasic-scan`` is the strongest fill measured on the KITTI slice, and a
learned blend of classical fills trained on scans is worse there (1.06-1.12x the mean with
one recording day left out, experiments/scan_lodo.py); in a hole cut into the scan, or a
large gap, the blend is far better. So each pixel to fill is gated by its distance to the
nearest measurement: up to ``near_distance`` pixels it takes the mean of the ``near_fills``
candidates, beyond it the blend, which is trained on those far pixels only. The network
runs on the far pixels only, which keeps ``predict`` near the cost of its candidates.

>>> from estimators.learned import load_release                          # doctest: +SKIP
>>> est = load_release("kitti-scan-v1")
>>> est.predict(scan_with_nan)                                          # metres
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from inpaintenv.exceptions import InvalidInputError

from ._blend import BlendInpainter
from .._constraints import Check, Real
from ._far import far_pixels
from .nets import pixel_blend
from ..candidates import check_candidates

__all__ = ["NEAR_FILLS", "SCAN_CANDIDATES", "ScanBlendInpainter"]

#: Candidates of the scan blend: the two fills of the classical mean (which serve the near
#: pixels too, computed once), the nearest measurement, and how near / far the rest of the
#: pixel's rows reach (what a hole hides). Chosen with one recording day left out
#: (docs/model_cards/kitti-scan-v1.md): as good in the hole as seven fills, at less cost.
SCAN_CANDIDATES: tuple[str, ...] = ("harmonic", "ipbasic-scan", "nearest", "row-median", "row-far")
#: The candidates whose mean fills the pixels near a measurement: ``harmonic-ipbasic``.
NEAR_FILLS: tuple[str, ...] = ("harmonic", "ipbasic-scan")

class ScanBlendInpainter(BlendInpainter):
    """A classical mean near a scan's measurements, a learned blend of classical fills far from them.

    Parameters
    ----------
    candidates : tuple of str, default :data:`SCAN_CANDIDATES`
        Classical fills the blend chooses between; must hold every ``near_fills`` name.
    near_fills : tuple of str, default :data:`NEAR_FILLS`
        Candidates whose per-pixel mean fills the pixels near a measurement (the default:
        the classical ``harmonic-ipbasic``).
    near_distance : float, default 16.0
        Pixels farther than this from the nearest measurement (Euclidean, in pixels) and
        within the rows the measurements span take the blend; the others the mean. The
        blend trains on such far pixels only.
    width : int, default 64
        Hidden units per layer.
    epochs : int, default 8
        Passes over the pooled pixels.
    tta : bool, default False
        Average with the mirrored frame's prediction: within 0.004 of the ratio without it in
        the hole on every left-out day, at twice the network's time.
    endpoints, layers, relative, residual, keep, masks_per_frame, pixels_per_frame, max_pixels, batch_pixels, lr, protocol, random_state, num_threads, predict_threads, n_jobs, keep_observed, verbose
        As :class:`~estimators.learned.BlendInpainter`.

    Notes
    -----
    Trained on a scan dataset (``input_kind == "scan"``) it learns from the scan's far
    pixels, half of them inside ``protocol``'s holes; on a map it learns from the map's.
    """

    #: Trains only on pixels far from every measurement (the shared checks skip scikit-learn's
    #: fits on small tables, which have none).
    _learns_far_pixels = True

    def __init__(
        self,
        *,
        candidates: tuple[str, ...] = SCAN_CANDIDATES,
        near_fills: tuple[str, ...] = NEAR_FILLS,
        near_distance: float = 16.0,
        endpoints: bool = True,
        width: int = 64,
        layers: int = 2,
        relative: bool = True,
        residual: bool = True,
        keep: tuple[float, ...] = (1.0,),
        masks_per_frame: int = 3,
        pixels_per_frame: int = 3000,
        max_pixels: int | None = 20_000_000,
        epochs: int = 8,
        batch_pixels: int = 8192,
        lr: float = 2e-3,
        protocol: str = "rect-v1",
        tta: bool = False,
        random_state: Any = 0,
        num_threads: int | None = None,
        predict_threads: int | None = 1,
        n_jobs: int | None = None,
        keep_observed: bool = True,
        verbose: bool = False,
    ):
        super().__init__(
            candidates=candidates, endpoints=endpoints, width=width, layers=layers, relative=relative,
            residual=residual, keep=keep, masks_per_frame=masks_per_frame, pixels_per_frame=pixels_per_frame,
            max_pixels=max_pixels, epochs=epochs, batch_pixels=batch_pixels, lr=lr, protocol=protocol, tta=tta,
            random_state=random_state, num_threads=num_threads, predict_threads=predict_threads, n_jobs=n_jobs,
            keep_observed=keep_observed, verbose=verbose,
        )
        self.near_fills = near_fills
        self.near_distance = near_distance

    _TUPLE_PARAMS: tuple[str, ...] = ("candidates", "keep", "near_fills")

    _parameter_constraints: dict[str, list[Any]] = {
        **BlendInpainter._parameter_constraints,
        "near_fills": [Check(lambda names: check_candidates(names, "near_fills"))],
        "near_distance": [Real(0)],
    }

    def _check_param_relations(self) -> None:
        super()._check_param_relations()
        missing = [n for n in self.near_fills if n not in self.candidates]
        if missing:
            raise InvalidInputError(f"near_fills {missing} must be among the candidates {tuple(self.candidates)}")

    def _min_distance(self) -> float | None:
        return float(self.near_distance)

    def _predict_features(self, frame: np.ndarray, feats: np.ndarray) -> np.ndarray:
        far = far_pixels(frame, float(self.near_distance))
        names = tuple(self.candidates)
        near = feats[[3 + names.index(n) for n in self.near_fills]].mean(axis=0)
        feats[1] = far  # the hole channel: where the network runs (it is no input of the network)
        pred = pixel_blend.fill_holes(self.model_, torch.from_numpy(feats[None]), flip_average=bool(self.tta))[0]
        measured = feats[2] > 0.5
        return np.where(measured | far, pred.numpy(), near).astype(np.float32)


# estimators.learned.load finds classes by the name a checkpoint records.
