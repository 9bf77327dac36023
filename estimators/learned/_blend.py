"""BlendInpainter: a learned per-pixel blend of classical fills, trained in minutes.

For every pixel to fill, a small MLP (:class:`~estimators.learned.nets.pixel_blend.PixelBlendNet`)
reads classical candidate fills (row- and column-wise interpolation of depth and inverse
depth, harmonic interpolation of inverse depth), the gap lengths to the nearest
measurement in the four directions and those measurements' depths, and outputs blend
weights for the candidates plus a scale-free residual.

The candidates are the expensive part, and they depend only on the frame and its hole,
so ``fit`` computes them once per (frame, occlusion), samples hole pixels with ground
truth, and trains the MLP on the pooled pixels for a few epochs. Training on a few
hundred KITTI frames takes minutes on a CPU (the step-based loop of
:class:`~estimators.learned.PriorUNetInpainter` recomputes the candidates at every step).
Prediction runs the MLP on the pixels to fill only.

>>> from estimators.learned import BlendInpainter                     # doctest: +SKIP
>>> est = BlendInpainter(epochs=3).fit(frames)                       # minutes on a CPU
>>> est.predict(depth_with_nan_holes)                                # metres
"""

from __future__ import annotations

import time
import warnings
from typing import Any

import numpy as np
import torch
from joblib import Parallel, delayed

from inpaintenv.conventions import check_depth
from inpaintenv.data.base import DepthDataset
from inpaintenv.data.inputs import method_input
from inpaintenv.report.provenance import environment_info
from inpaintenv.exceptions import InvalidInputError
from inpaintenv.masks import get_protocol
from inpaintenv.progress import FrameProgress

from ..base import BaseInpainter, check_n_jobs, check_random_state, resolve_seed
from ..candidates import (
    ENDPOINT_CHANNELS,
    GAP_CHANNELS,
    check_candidates,
    prior_features,
)
from . import _checkpoint as ckpt
from .._constraints import Bool, Check, ConstrainedParams, Integer, Real, Sequence
from ._far import far_pixels
from ._limits import MAX_LAYERS, MAX_THREADS, MAX_WIDTH, check_parameter_count
from ._persistence import PersistenceMixin, json_params
from ._pixel_model import check_model_params, config_params, fit_record, fit_rows, predict_frames, read_fit_record
from ._loop import seeded
from ._training import deterministic_torch, frame_label, torch_threads
from ._training_data import input_frame, scan_input
from .nets import pixel_blend
from .nets.pixel_blend import PixelBlendNet

__all__ = ["BLEND_CANDIDATES", "BlendInpainter"]

#: Default candidates: cheap row/column scans (one scan per axis serves all four, see
#: :mod:`estimators._scan`) and the harmonic fill of inverse depth.
BLEND_CANDIDATES: tuple[str, ...] = (
    "scanline", "scanline-inverse", "vertical", "vertical-inverse", "harmonic-inverse",
)



def _pick(mask: np.ndarray, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Rows and columns of up to ``n`` of ``mask``'s pixels, drawn without replacement, in raster order."""
    rows, cols = np.nonzero(mask)
    if len(rows) > n:
        pick = np.sort(rng.choice(len(rows), n, replace=False))
        rows, cols = rows[pick], cols[pick]
    return rows, cols


def _pixel_samples(
    gt: np.ndarray, source: np.ndarray, hole: np.ndarray, keep: float, n_pixels: int, names: tuple[str, ...],
    endpoints: bool, scan: bool, rng: np.random.Generator, min_distance: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Features and ground truth of up to ``n_pixels`` pixels to fill that have ground truth.

    ``source`` is the measured input (``gt`` itself for a map; the frame's scan for a scan,
    whose every unmeasured pixel is to be filled, not only the hole). ``min_distance``: only
    pixels farther than that from any measurement (:func:`~._far.far_pixels`).
    """
    if keep < 1.0:
        # Sparser input than the one given (official KITTI maps are sparser than rebuilt
        # ones): drop measured pixels outside the hole.
        source = np.where((source > 0) & ~hole & (rng.random(gt.shape) >= keep), 0.0, source)
    x = method_input(source, hole, "scan" if scan else "map")
    target = np.isnan(x) & (gt > 0)
    if min_distance is not None:
        target &= far_pixels(x, min_distance)
    if scan and (target & hole).any():
        # Half in the hole, half among the unmeasured pixels around it: a scan's unmeasured
        # pixels outnumber a hole's many times, and both tasks are scored.
        inside, outside = _pick(target & hole, n_pixels - n_pixels // 2, rng), _pick(target & ~hole, n_pixels // 2, rng)
        rows, cols = np.concatenate([inside[0], outside[0]]), np.concatenate([inside[1], outside[1]])
    else:
        rows, cols = _pick(target, n_pixels, rng)
    feats = prior_features(x, names, gaps=True, endpoints=endpoints)[3:]
    return feats[:, rows, cols].T.copy(), gt[rows, cols].astype(np.float32)


class BlendInpainter(ConstrainedParams, PersistenceMixin, BaseInpainter):
    """Learned per-pixel blend of classical fills plus a scale-free residual.

    Parameters
    ----------
    candidates : tuple of str, default :data:`BLEND_CANDIDATES`
        Classical fills the blend chooses between (any of
        :data:`estimators.candidates.AVAILABLE_CANDIDATES`).
    endpoints : bool, default True
        Also give the depth of the nearest measurement left, right, above and below.
    width : int, default 64
        Hidden units per layer.
    layers : int, default 2
        Hidden layers.
    relative : bool, default True
        Scale-free blend: depths enter as log-ratios to the candidates' geometric mean
        and the residual is a fraction of it, so a frame twice as deep gets a
        prediction twice as deep (the model cannot key on one drive's depth range).
    residual : bool, default True
        Add a learned residual (a fraction of the candidates' geometric mean) to the
        blend; False keeps every prediction within the candidates' range.
    keep : tuple of float, default (1.0,)
        Training inputs per occlusion, one per fraction of the measured pixels kept
        outside the hole (e.g. ``(1.0, 0.65)`` adds a thinned copy, closer to the
        sparser official KITTI maps).
    masks_per_frame : int, default 3
        Occlusions drawn per training frame (from ``protocol``).
    pixels_per_frame : int, default 3000
        Hole pixels with ground truth sampled per (frame, occlusion, keep).
    max_pixels : int or None, default 20_000_000
        Cap on the pooled training pixels: 14 float32 values each at the default
        inputs, so 1.1 GB. Where frames × ``masks_per_frame`` × ``len(keep)`` ×
        ``pixels_per_frame`` would exceed it, fewer pixels are sampled per (frame,
        occlusion, keep), at least one, with a warning; None: no cap. Uncapped, the
        ``blend-kitti`` preset (3 occlusions × 3 keep fractions × 3000 pixels) on the
        85,898 frames of KITTI's training release would need 130 GB.
    epochs : int, default 4
        Passes over the pooled pixels.
    batch_pixels : int, default 8192
        Pixels per optimiser step.
    lr : float, default 2e-3
        Peak learning rate (one-cycle schedule, Adam).
    protocol : str, default "rect-v1"
        Occlusion protocol of training.
    tta : bool, default True
        Average each prediction with that of the mirrored frame.
    random_state : int, RandomState, Generator or None, default 0
        Seeds occlusions, pixel sampling, thinning, initialisation and batch order; None
        draws a fresh seed per fit, a RandomState or Generator gives its next number
        (the seed used is ``seed_``).
    num_threads : int, optional
        torch threads while fitting (None: leave torch's setting).
    predict_threads : int or None, default 1
        torch threads while predicting (None: leave torch's setting). One is the
        default: the network's share of a frame is ~30 ms, threads gain little on it,
        and on a busy machine (the benchmark beside other work) two threads made
        ``predict`` 2.3x slower than one (471 vs 205 ms per KITTI frame, measured with
        ``perf/bench_blend.py`` while two benchmarks ran). Parallelise over
        frames instead (``inpaintenv benchmark --scheduler local:N``).
    n_jobs : int, optional
        Frames whose features are computed in parallel during ``fit`` (joblib threads;
        None = 1, -1 = all cores).
    keep_observed : bool, default True
        Return measured input pixels unchanged.
    verbose : bool or int, default False
        Progress of ``fit`` when true or > 0 (as scikit-learn's ``verbose``): a bar on a
        terminal, one line per epoch in a log.

    Attributes
    ----------
    model_ : PixelBlendNet
    history_ : dict
        ``epoch_loss``: mean training MSE (m²) per epoch.
    n_pixels_ : int
        Training pixels.
    pixels_per_sample_ : int
        Hole pixels sampled per (frame, occlusion, keep): ``pixels_per_frame``, or fewer
        under ``max_pixels``.
    fit_seconds_ : float
        Wall-clock time of ``fit``.
    training_frames_ : int
        Frames with ground truth used.

    Notes
    -----
    Every candidate is mirror-symmetric, so the flip average needs no second frame: a
    mirrored pixel's features are its own with the left/right channels swapped. Pixels
    with no measurement outside the holes (LiDAR gaps) take the candidates' mean; the
    network runs on the pixels to fill (NaN) only, which is what keeps it fast.
    """

    #: What ``history_["epoch_loss"]`` is, with its unit (the y axis of ``inpaintenv train``'s loss.png).
    loss_label = "training loss: mean squared error (m²)"

    def __init__(
        self,
        *,
        candidates: tuple[str, ...] = BLEND_CANDIDATES,
        endpoints: bool = True,
        width: int = 64,
        layers: int = 2,
        relative: bool = True,
        residual: bool = True,
        keep: tuple[float, ...] = (1.0,),
        masks_per_frame: int = 3,
        pixels_per_frame: int = 3000,
        max_pixels: int | None = 20_000_000,
        epochs: int = 4,
        batch_pixels: int = 8192,
        lr: float = 2e-3,
        protocol: str = "rect-v1",
        tta: bool = True,
        random_state: Any = 0,
        num_threads: int | None = None,
        predict_threads: int | None = 1,
        n_jobs: int | None = None,
        keep_observed: bool = True,
        verbose: bool = False,
    ):
        self.candidates = candidates
        self.endpoints = endpoints
        self.width = width
        self.layers = layers
        self.relative = relative
        self.residual = residual
        self.keep = keep
        self.masks_per_frame = masks_per_frame
        self.pixels_per_frame = pixels_per_frame
        self.max_pixels = max_pixels
        self.epochs = epochs
        self.batch_pixels = batch_pixels
        self.lr = lr
        self.protocol = protocol
        self.tta = tta
        self.random_state = random_state
        self.num_threads = num_threads
        self.predict_threads = predict_threads
        self.n_jobs = n_jobs
        self.keep_observed = keep_observed
        self.verbose = verbose

    #: Parameters stored as JSON lists that the constructor takes as tuples.
    _TUPLE_PARAMS: tuple[str, ...] = ("candidates", "keep")

    # -- parameters ----------------------------------------------------------------------
    _parameter_constraints: dict[str, list[Any]] = {
        "candidates": [Check(check_candidates)],
        "endpoints": [Bool()],
        "width": [Integer(1, limit=MAX_WIDTH)],
        "layers": [Integer(1, limit=MAX_LAYERS)],
        "relative": [Bool()],
        "residual": [Bool()],
        "keep": [Sequence(Real(0, 1, closed="right"), noun="a non-empty tuple of fractions in (0, 1]")],
        "masks_per_frame": [Integer(1)],
        "pixels_per_frame": [Integer(1)],
        "max_pixels": [Integer(1), None],
        "epochs": [Integer(1)],
        "batch_pixels": [Integer(1)],
        "lr": [Real(0, closed="neither")],
        "protocol": [Check(get_protocol)],  # an unknown name lists the known protocols
        "tta": [Bool()],
        "num_threads": [Integer(1, limit=MAX_THREADS), None],
        "predict_threads": [Integer(1, limit=MAX_THREADS), None],
        "n_jobs": [Check(check_n_jobs), None],  # joblib's meaning, as the classical methods take it
        "random_state": [Check(check_random_state)],
        "keep_observed": [Bool()],
        "verbose": [Bool(), Integer(0)],
    }

    def _model_params(self) -> dict[str, Any]:
        """The parameters the weights depend on."""
        return {"candidates": list(self.candidates), "endpoints": bool(self.endpoints), "width": int(self.width),
                "layers": int(self.layers), "relative": bool(self.relative), "residual": bool(self.residual)}

    _check_model_params = check_model_params

    def _check_size(self) -> None:
        """Refuse a network of more than ``MAX_PARAMETERS`` (counted before it is built)."""
        check_parameter_count(self._build_model, ", ".join(
            f"{k}={v!r}" for k, v in self._model_params().items() if k != "candidates"))

    def _build_model(self) -> PixelBlendNet:
        return PixelBlendNet(len(self.candidates), len(GAP_CHANNELS), int(self.width), int(self.layers),
                             n_endpoints=len(ENDPOINT_CHANNELS) if self.endpoints else 0,
                             relative=bool(self.relative), residual=bool(self.residual))

    # -- fitting ---------------------------------------------------------------------------
    def _fit(self, dataset: DepthDataset) -> None:
        self._check_params()
        self._check_size()
        start = time.perf_counter()
        seed = resolve_seed(self.random_state)  # one draw per fit: features and network share it
        x, y = self.training_pixels(dataset, seed=seed)
        if not len(y):
            raise InvalidInputError("no training frame has ground truth inside its sampled holes; nothing to learn")
        with torch_threads(self.num_threads), deterministic_torch():
            self.fit_environment_ = environment_info(torch_details=True)
            self.model_, self.history_ = self._fit_pixels(x, y, seed)
        self.seed_ = seed
        self.model_params_ = self._model_params()
        self.n_pixels_ = len(y)
        self.fit_seconds_ = time.perf_counter() - start

    def training_pixels(self, dataset: DepthDataset, seed: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Features ``(P, C)`` and ground truth ``(P,)`` of the sampled training pixels.

        Frame ``i`` gets ``masks_per_frame`` occlusions from its own random stream
        (``seed``, ``i``), independent of the evaluation masks
        (``protocol.mask(shape, seed, i)``), and one input per ``keep`` fraction. ``seed``
        defaults to the one ``random_state`` gives (:func:`~estimators.base.resolve_seed`).
        """
        if seed is None:
            seed = resolve_seed(self.random_state)
        protocol = get_protocol(self.protocol)
        names, endpoints = tuple(self.candidates), bool(self.endpoints)
        n_pixels = self._pixels_per_sample(len(dataset))
        scan = scan_input(dataset)

        def one_frame(i: int) -> list[tuple[np.ndarray, np.ndarray]]:
            gt = check_depth(dataset[i], name=f"training frame {frame_label(dataset, i)}", ndim=(2,))
            if not (gt > 0).any():
                return []
            source = input_frame(dataset, i, gt)
            rng = np.random.default_rng([int(seed), i, 0xB1E9D])
            out = []
            for _ in range(int(self.masks_per_frame)):
                hole = protocol.sample(gt.shape, rng)
                out += [_pixel_samples(gt, source, hole, float(k), n_pixels, names, endpoints, scan, rng,
                                       self._min_distance()) for k in self.keep]
            return out

        jobs = self._map_frames(one_frame, len(dataset), "training features")
        parts = [p for frame in jobs for p in frame]
        self.training_frames_ = sum(1 for frame in jobs if frame)
        if not parts:
            return np.zeros((0, 0), np.float32), np.zeros(0, np.float32)
        return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])

    def _min_distance(self) -> float | None:
        """Train only on pixels farther than this from any measurement (None: every pixel to fill)."""
        return None

    def _map_frames(self, one_frame: Any, n_frames: int, what: str) -> list:
        """``[one_frame(i) for i in range(n_frames)]``, ``n_jobs`` frames at a time (joblib
        threads, or the active joblib backend), in order, with one progress display (frames
        done of total, rate, time left) when ``verbose`` instead of joblib's own lines."""
        out = []
        with FrameProgress(n_frames, what, enabled=bool(self.verbose)) as progress:
            for result in Parallel(n_jobs=self.n_jobs, prefer="threads", return_as="generator")(
                delayed(one_frame)(i) for i in range(n_frames)
            ):
                out.append(result)
                progress.update(1)
        return out

    def _pixels_per_sample(self, n_frames: int) -> int:
        """``pixels_per_frame``, lowered so that ``n_frames`` frames stay within ``max_pixels``."""
        per = int(self.pixels_per_frame)
        samples = n_frames * int(self.masks_per_frame) * len(self.keep)
        if self.max_pixels is not None and samples * per > self.max_pixels:
            per = max(1, int(self.max_pixels) // max(samples, 1))
            warnings.warn(
                f"{n_frames} frames x {self.masks_per_frame} occlusion(s) x {len(self.keep)} keep fraction(s) x "
                f"{self.pixels_per_frame} pixels = {samples * int(self.pixels_per_frame)} training pixels exceed "
                f"max_pixels={self.max_pixels}: sampling {per} pixels per (frame, occlusion, keep) instead "
                "(raise max_pixels if memory allows)",
                UserWarning, stacklevel=3,
            )
        self.pixels_per_sample_ = per
        return per

    def _fit_pixels(self, x: np.ndarray, y: np.ndarray, seed: int) -> tuple[PixelBlendNet, dict[str, list[float]]]:
        """Train a fresh network on pixel features ``x`` (``(P, C)``) and depths ``y`` (metres)
        through :func:`~._pixel_model.fit_rows`: each epoch a fresh order of the pixels, ``batch_pixels`` a step."""
        net = seeded(self._build_model, seed)
        rng = np.random.default_rng([seed, 0x5EED])
        xt, yt = torch.from_numpy(np.ascontiguousarray(x, np.float32)), torch.from_numpy(y)
        mirrored = net.mirror_order()

        def batch_loss(idx: torch.Tensor) -> Any:
            xb = xt[idx]
            if rng.random() < 0.5:  # flip augmentation: the mirrored frame's pixels
                xb = xb[:, mirrored]
            return lambda: (net.blend(xb) - yt[idx]).square().mean()

        return net, fit_rows(net, len(y), int(self.batch_pixels), self, rng, batch_loss)

    # -- prediction ------------------------------------------------------------------------
    def _predict_batch(self, X: np.ndarray) -> np.ndarray:
        return predict_frames(self, X, self.predict_threads)

    def _predict_frame(self, frame: np.ndarray) -> np.ndarray:
        return self._predict_features(frame, self._features(frame))

    def _features(self, frame: np.ndarray) -> np.ndarray:
        """The candidate features of one frame (what :meth:`_predict_features` reads)."""
        return prior_features(frame, tuple(self.candidates), gaps=True, endpoints=bool(self.endpoints))

    def _predict_features(self, frame: np.ndarray, feats: np.ndarray) -> np.ndarray:
        """One frame filled from its features (models with the same features can share them)."""
        return pixel_blend.fill_holes(self.model_, torch.from_numpy(feats[None]), flip_average=bool(self.tta))[0].numpy()

    # -- persistence (the hooks of PersistenceMixin) ------------------------------------------
    def _config(self) -> tuple[dict[str, Any], dict[str, torch.Tensor]]:
        self._check_model_params()
        params = json_params(self)
        config = {"params": params, "model_params": self.model_params_, "fit": fit_record(self)}
        return config, self.model_.state_dict()

    @classmethod
    def _from_config(cls, config: dict[str, Any], weights: dict[str, torch.Tensor], where: Any) -> BlendInpainter:
        params, model_params = config_params(cls, config, where)
        fitted = read_fit_record(config, where)
        est = ckpt.build_checked(cls, params, where)
        for name, value in fitted.items():
            setattr(est, name, value)
        est.model_ = ckpt.load_weights(est._build_model(), weights, where)
        est.model_params_ = model_params
        return est


# estimators.learned.load finds classes by the name a checkpoint records.
