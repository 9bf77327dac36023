"""SparseResidualInpainter: ``harmonic`` plus a learned per-pixel correction, for sparse LiDAR scans.

On a scan with fewer laser rings than KITTI's 64 (32, 16, 8 beams) the classical ``harmonic``
fill is the strongest single fill measured on the KITTI slice. This estimator keeps it as the
base and adds, at every pixel to fill, a correction read by a small MLP
(:class:`~estimators.learned.nets.residual_mlp.ResidualMLP`) from the pixel's features
(:func:`estimators.candidates.residual_features`): classical fills, the gaps to and depths of the nearest
measurements left, right, above and below (:func:`estimators.candidates.prior_features`), the
distance to the nearest measurement and the measured share of the 61 x 61 box around the pixel.

``fit`` reads the scans of a scan dataset, keeps every k-th laser ring of each for every k of
``rings`` (:func:`inpaintenv.data.thinning.thin_scan_by_rings`), samples unmeasured pixels with
ground truth, and trains the MLP on ``truth - harmonic`` (mean squared error, metres²) over
the pooled pixels of every density at once.

>>> from estimators.learned import SparseResidualInpainter             # doctest: +SKIP
>>> est = SparseResidualInpainter().fit(KittiDepth(root, input="scan"))
>>> est.predict(sparse_scan_with_nan)                                 # metres
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import torch

from inpaintenv.data.base import DepthDataset
from inpaintenv.data.inputs import method_input
from inpaintenv.exceptions import InvalidInputError
from inpaintenv.progress import FrameProgress
from inpaintenv.report.provenance import environment_info

from ..base import BaseInpainter, check_random_state, resolve_seed
from .._residual_features import overlap
from ..candidates import ENDPOINT_CHANNELS, GAP_CHANNELS, check_candidates, residual_channels, residual_features
from .._constraints import Bool, Check, ConstrainedParams, Integer, Real, Sequence
from . import _checkpoint as ckpt
from ._limits import MAX_LAYERS, MAX_THREADS, MAX_WIDTH, check_parameter_count
from ._loop import seeded
from ._persistence import PersistenceMixin, json_params
from ._pixel_model import check_model_params, config_params, fit_record, fit_rows, predict_frames, read_fit_record
from ._training import deterministic_torch, frame_label, torch_threads
from ._training_data import input_frame, scan_input
from .nets.pixel_blend import CHUNK
from .nets.residual_mlp import ResidualMLP

__all__ = ["RESIDUAL_FILLS", "SparseResidualInpainter"]

#: Default fills read beside ``harmonic``: how near / far the pixel's row and its window
#: reach, and the nearest measurement (the set of ``experiments/scan_lodo.py``'s probe).
RESIDUAL_FILLS: tuple[str, ...] = ("row-median", "row-far", "window-near", "window-far", "nearest")
#: The largest ring step: one ring in 64 keeps a single ring of KITTI's HDL-64E.
MAX_RING_STEP = 64


def _n_features(fills: tuple[str, ...]) -> int:
    return 1 + len(fills) + len(GAP_CHANNELS) + len(ENDPOINT_CHANNELS) + 2


class SparseResidualInpainter(ConstrainedParams, PersistenceMixin, BaseInpainter):
    """``harmonic`` plus a learned per-pixel correction, trained on scans thinned to several densities.

    Parameters
    ----------
    fills : tuple of str, default :data:`RESIDUAL_FILLS`
        Classical fills read beside ``harmonic`` (any of
        :data:`estimators.candidates.AVAILABLE_CANDIDATES`); ``harmonic`` is always the base
        and the first feature.
    width : int, default 32
        Hidden units per layer.
    layers : int, default 2
        Hidden layers.
    epochs : int, default 10
        Passes over the pooled pixels.
    lr : float, default 1e-3
        Peak learning rate (one-cycle schedule, Adam).
    batch_pixels : int, default 1024
        Pixels per optimiser step.
    pixels_per_frame : int, default 4000
        Unmeasured pixels with ground truth sampled per (frame, ring step).
    rings : tuple of int, default (2, 4, 8)
        Training inputs per frame: the dataset's scan with every k-th laser ring kept, one per
        k (2, 4, 8: 32, 16, 8 of KITTI's 64 beams; 1: the scan as it is). Give the dataset
        the 64-beam scan (``input="scan"``); a k above 1 needs the dataset's calibrations
        (:meth:`~inpaintenv.data.DepthDataset.scan_calibration`).
    shrink : float in (0, 1], default 1.0
        The correction is multiplied by it at ``predict`` (1: as fitted; towards 0: towards
        ``harmonic``). It changes neither ``fit`` nor the weights, so one fitted model can be
        scored at several shrinks (``set_params(shrink=...)`` on a copy).
    random_state : int, RandomState, Generator or None, default 0
        Seeds pixel sampling, initialisation and batch order; None draws a fresh seed per
        fit (the seed used is ``seed_``).
    num_threads : int, optional
        torch threads while fitting (None: leave torch's setting).
    predict_threads : int or None, default 1
        torch threads while predicting (None: leave torch's setting). The network's share of
        a 16-beam KITTI frame is ~40 ms on one thread; with torch's default of one thread per
        core, a 2-core machine with other work on it (load average 3.6-4.2) took 2.9 s per
        frame instead of ~0.13 s (``perf/bench_sparse_residual.py --threads 2``). Parallelise
        over frames instead.
    verbose : bool or int, default False
        Progress of ``fit`` when true or > 0.

    Attributes
    ----------
    model_ : ResidualMLP
    feature_mean_, feature_std_ : numpy.ndarray
        ``(C,)`` float32 standardisation of the features, from the training pixels.
    history_ : dict
        ``epoch_loss``: mean training MSE (m²) per epoch.
    n_pixels_ : int
        Training pixels.
    training_frames_ : int
        Frames with ground truth used.
    fit_seconds_ : float
        Wall-clock time of ``fit``.

    Notes
    -----
    Measured pixels are returned unchanged; every pixel to fill gets ``harmonic`` plus the
    correction, bounded like every learned output (:func:`~._output.bound_output`). The
    network runs on the pixels to fill only, in chunks.
    """

    #: What ``history_["epoch_loss"]`` is, with its unit.
    loss_label = "training loss: mean squared error of the correction (m²)"
    #: Learns from scans only (the shared checks fit it on a scan view of their frames).
    _needs_scans = True

    def __init__(
        self,
        *,
        fills: tuple[str, ...] = RESIDUAL_FILLS,
        width: int = 32,
        layers: int = 2,
        epochs: int = 10,
        lr: float = 1e-3,
        batch_pixels: int = 1024,
        pixels_per_frame: int = 4000,
        rings: tuple[int, ...] = (2, 4, 8),
        shrink: float = 1.0,
        random_state: Any = 0,
        num_threads: int | None = None,
        predict_threads: int | None = 1,
        verbose: bool = False,
    ):
        self.fills = fills
        self.width = width
        self.layers = layers
        self.epochs = epochs
        self.lr = lr
        self.batch_pixels = batch_pixels
        self.pixels_per_frame = pixels_per_frame
        self.rings = rings
        self.shrink = shrink
        self.random_state = random_state
        self.num_threads = num_threads
        self.predict_threads = predict_threads
        self.verbose = verbose

    #: Parameters stored as JSON lists that the constructor takes as tuples.
    _TUPLE_PARAMS: tuple[str, ...] = ("fills", "rings")

    _parameter_constraints: dict[str, list[Any]] = {
        "fills": [Check(lambda names: check_candidates(names, "fills"))],
        "width": [Integer(1, limit=MAX_WIDTH)],
        "layers": [Integer(1, limit=MAX_LAYERS)],
        "epochs": [Integer(1)],
        "lr": [Real(0, closed="neither")],
        "batch_pixels": [Integer(1)],
        "pixels_per_frame": [Integer(1)],
        "rings": [Sequence(Integer(1, high=MAX_RING_STEP), max_len=16,
                           noun=f"a non-empty tuple of ring steps from 1 to {MAX_RING_STEP}")],
        "shrink": [Real(0, 1, closed="right")],
        "random_state": [Check(check_random_state)],
        "num_threads": [Integer(1, limit=MAX_THREADS), None],
        "predict_threads": [Integer(1, limit=MAX_THREADS), None],
        "verbose": [Bool(), Integer(0)],
    }

    def _model_params(self) -> dict[str, Any]:
        """The parameters the weights depend on."""
        return {"fills": list(self.fills), "width": int(self.width), "layers": int(self.layers)}

    _check_model_params = check_model_params

    def _build_model(self) -> ResidualMLP:
        return ResidualMLP(_n_features(tuple(self.fills)), int(self.width), int(self.layers))

    def _check_size(self) -> None:
        """Refuse a network of more than ``MAX_PARAMETERS`` (counted before it is built)."""
        check_parameter_count(self._build_model, f"width={self.width!r}, layers={self.layers!r}")

    # -- fitting ---------------------------------------------------------------------------
    def _fit(self, dataset: DepthDataset) -> None:
        self._check_params()
        self._check_size()
        if not scan_input(dataset):
            raise InvalidInputError(
                f"{type(self).__name__} learns from LiDAR scans: fit it on a dataset whose input is a scan "
                f"(e.g. KittiDepth(root, input='scan')), not one of input kind {dataset.input_kind!r}")
        start = time.perf_counter()
        seed = resolve_seed(self.random_state)
        x, y = self.training_pixels(dataset, seed=seed)
        if not len(y):
            raise InvalidInputError("no training frame has an unmeasured pixel with ground truth; nothing to learn")
        mean = x.mean(axis=0, dtype=np.float64)
        std = x.std(axis=0, dtype=np.float64)
        std[std < 1e-6] = 1.0  # a constant feature: centred, not scaled up
        self.feature_mean_, self.feature_std_ = mean.astype(np.float32), std.astype(np.float32)
        with torch_threads(self.num_threads), deterministic_torch():
            self.fit_environment_ = environment_info(torch_details=True)
            self.model_, self.history_ = self._fit_pixels(self._standardised(x), y, seed)
        self.seed_ = seed
        self.model_params_ = self._model_params()
        self.n_pixels_ = len(y)
        self.fit_seconds_ = time.perf_counter() - start

    def training_pixels(self, dataset: DepthDataset, seed: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Features ``(P, C)`` (not standardised) and targets ``truth - harmonic`` ``(P,)`` of the
        sampled training pixels: up to ``pixels_per_frame`` per (frame, ring step), drawn from the
        stream ``(seed, frame, step)``."""
        if seed is None:
            seed = resolve_seed(self.random_state)
        fills, n_pixels = tuple(self.fills), int(self.pixels_per_frame)
        feats, targets, used = [], [], 0
        with FrameProgress(len(dataset), "training features", enabled=bool(self.verbose)) as progress:
            for i in range(len(dataset)):
                gt = dataset.checked_frame(i, f"training frame {frame_label(dataset, i)}")
                if (gt > 0).any():
                    used += 1
                    for j, x in enumerate(self._training_inputs(dataset, i, gt)):
                        if not (x > 0).any():
                            continue  # no measurement left to fill from
                        rng = np.random.default_rng([int(seed), i, j, 0x5BA5E])
                        rows, cols = np.nonzero(np.isnan(x) & (gt > 0))
                        if len(rows) > n_pixels:
                            pick = np.sort(rng.choice(len(rows), n_pixels, replace=False))
                            rows, cols = rows[pick], cols[pick]
                        f, harmonic = residual_features(x, fills, (rows, cols))
                        feats.append(f)
                        targets.append((gt[rows, cols] - harmonic).astype(np.float32))
                progress.update(1)
        self.training_frames_ = used
        if not feats:
            return np.zeros((0, _n_features(fills)), np.float32), np.zeros(0, np.float32)
        return np.concatenate(feats), np.concatenate(targets)

    def _training_inputs(self, dataset: DepthDataset, index: int, gt: np.ndarray) -> list[np.ndarray]:
        """Frame ``index``'s scan with every k-th ring kept, one per k of ``rings``, NaN = to fill."""
        from inpaintenv.data.thinning import thin_scan_by_rings  # noqa: PLC0415 - only fit thins

        scan = input_frame(dataset, index, gt)
        calibration = dataset.scan_calibration(index) if any(int(k) > 1 for k in self.rings) else None
        out = []
        for k in self.rings:
            thinned = scan if int(k) == 1 else thin_scan_by_rings(
                scan, calibration[0], int(k), laser_height=calibration[1])
            out.append(method_input(thinned, np.zeros(scan.shape, bool), "scan"))
        return out

    def _standardised(self, x: np.ndarray) -> np.ndarray:
        return ((x - self.feature_mean_) / self.feature_std_).astype(np.float32, copy=False)

    def _fit_pixels(self, x: np.ndarray, y: np.ndarray, seed: int) -> tuple[ResidualMLP, dict[str, list[float]]]:
        """Train a fresh network on standardised features ``x`` and targets ``y`` (metres)."""
        net = seeded(self._build_model, seed)
        rng = np.random.default_rng([seed, 0x5EED])
        batch = min(int(self.batch_pixels), len(y))
        xt, yt = torch.from_numpy(np.ascontiguousarray(x)), torch.from_numpy(y)

        def batch_loss(idx: torch.Tensor) -> Any:
            return lambda: (net(xt[idx]) - yt[idx]).square().mean()

        return net, fit_rows(net, len(y), batch, self, rng, batch_loss)

    # -- prediction ------------------------------------------------------------------------
    def _predict_batch(self, X: np.ndarray) -> np.ndarray:
        return predict_frames(self, X, self.predict_threads)

    def _predict_frame(self, frame: np.ndarray) -> np.ndarray:
        todo = np.isnan(frame)
        if not (frame > 0).any():
            return np.zeros(frame.shape, np.float32)  # nothing to fill from (bound_output says 0 too)
        feats, harmonic = residual_channels(frame, tuple(self.fills), todo)
        out = np.array(frame, np.float32)
        out[todo] = harmonic + np.float32(self.shrink) * self._corrections(feats)
        return out

    def _corrections(self, feats: np.ndarray) -> np.ndarray:
        """The network's corrections ``(P,)`` of ``(C, P)`` features (standardised in place, as in training).

        The standardisation runs along contiguous channel rows; the network reads each chunk
        of pixels as a transposed view (a strided matrix product, no copy). On one torch thread,
        every other chunk goes to a worker thread while a core is free
        (:func:`~estimators._residual_features.overlap`): the same chunks, the same numbers.
        """
        np.subtract(feats, self.feature_mean_[:, None], out=feats)
        np.divide(feats, self.feature_std_[:, None], out=feats)
        pixels, out = torch.from_numpy(feats), np.empty(feats.shape[1], np.float32)
        starts = range(0, feats.shape[1], CHUNK)

        def run(part: range) -> None:
            with torch.inference_mode():  # per thread: a worker does not inherit the caller's mode
                for start in part:
                    out[start:start + CHUNK] = self.model_(pixels[:, start:start + CHUNK].T).numpy()

        with overlap(torch.get_num_threads() == 1) as worker:
            pending = worker.submit(lambda: run(starts[1::2]))
            run(starts[0::2])
            pending.result()
        return out

    # -- persistence (the hooks of PersistenceMixin) ------------------------------------------
    def _config(self) -> tuple[dict[str, Any], dict[str, torch.Tensor]]:
        self._check_model_params()
        params = json_params(self)
        config = {"params": params, "model_params": self.model_params_,
                  "standardise": {"mean": [float(v) for v in self.feature_mean_],
                                  "std": [float(v) for v in self.feature_std_]},
                  "fit": fit_record(self)}
        return config, self.model_.state_dict()

    @classmethod
    def _from_config(cls, config: dict[str, Any], weights: dict[str, torch.Tensor],
                     where: Any) -> SparseResidualInpainter:
        params, model_params = config_params(cls, config, where)
        est = ckpt.build_checked(cls, params, where)
        if model_params != est._model_params():
            raise ckpt.CheckpointError(f"{where}: model_params {model_params} are not the parameters' "
                                       f"{est._model_params()}")
        standardise = ckpt.config_value(config, "standardise", dict, where)
        n = _n_features(tuple(est.fills))
        mean, std = (_statistic(ckpt.config_value(standardise, k, list, where), k, n, where) for k in ("mean", "std"))
        if not (std > 0).all():
            raise ckpt.CheckpointError(f"{where}: config.json standardise 'std' must be positive")
        for name, value in read_fit_record(config, where).items():
            setattr(est, name, value)
        est.feature_mean_, est.feature_std_ = mean, std
        est.model_ = ckpt.load_weights(est._build_model(), weights, where)
        est.model_params_ = model_params
        return est


def _statistic(values: list, key: str, n: int, where: Any) -> np.ndarray:
    """A standardisation vector of ``n`` finite numbers from the config, or one CheckpointError."""
    if len(values) != n or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
        raise ckpt.CheckpointError(f"{where}: config.json standardise {key!r} must be {n} numbers")
    out = np.asarray(values, np.float64)
    if not np.isfinite(out).all():
        raise ckpt.CheckpointError(f"{where}: config.json standardise {key!r} must be finite")
    return out.astype(np.float32)


# estimators.learned.load finds classes by the name a checkpoint records.
