"""ContextBlendInpainter: the learned blend of classical fills, with a scene prior.

:class:`~estimators.learned.BlendInpainter` decides per pixel from what lies on the four
axis lines through it. Here a small U-Net also reads the whole frame at 1/8 scale
(:func:`~estimators.learned.nets.context_blend.context_grid`: measured log-depth, density, hole
and candidate fills, relative to the frame's median depth) and hands every pixel scene
features, trained together with the per-pixel MLP: where the road and the far scene
lie, how deep the other side of the hole is.

Training draws ``masks_per_frame`` occlusions per frame, computes the candidates once
per (frame, occlusion, keep fraction), keeps ``pixels_per_frame`` hole pixels and the
frame's context grid, then trains on batches of samples. Drives contribute equally
(``balance``): a long drive of near-identical consecutive frames would otherwise teach
the scene prior its own street.

>>> from estimators.learned import ContextBlendInpainter                # doctest: +SKIP
>>> est = ContextBlendInpainter(epochs=4).fit(frames)               # tens of minutes on a CPU
>>> est.predict(depth_with_nan_holes)                                # metres
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import torch
from torch import nn

from inpaintenv.conventions import check_depth
from inpaintenv.data.base import DepthDataset
from inpaintenv.report.provenance import environment_info
from inpaintenv.exceptions import InvalidInputError
from inpaintenv.masks import get_protocol

from ..base import resolve_seed
from ..candidates import prior_features
from ._blend import BLEND_CANDIDATES, BlendInpainter
from .._constraints import Integer, Options, Real, Sequence
from ._limits import MAX_LAYERS, MAX_MEMBERS, MAX_WIDTH
from ._loop import OneCycle, Optimisation, fit_loop, new_progress, seeded
from ._training import deterministic_torch, frame_label, torch_threads
from .nets.context_blend import ContextBlendEnsemble, ContextBlendNet, context_grid, frame_reference
from .nets.pixel_blend import CHUNK

__all__ = ["ContextBlendInpainter"]



def training_sample(
    gt: np.ndarray, hole: np.ndarray, keep: float, n_pixels: int, names: tuple[str, ...], rng: np.random.Generator,
) -> dict[str, np.ndarray]:
    """One (frame, occlusion, keep) sample: hole pixels' features and truth, and the context grid."""
    x = np.where(hole, np.nan, gt).astype(np.float32)
    if keep < 1.0:
        # Sparser input than the ground truth it comes from (official KITTI maps are sparser).
        x[(gt > 0) & ~hole & (rng.random(gt.shape) >= keep)] = 0.0
    feats = prior_features(x, names, gaps=True, endpoints=True)
    rows, cols = np.nonzero(hole & (gt > 0))
    if len(rows) > n_pixels:
        pick = np.sort(rng.choice(len(rows), n_pixels, replace=False))
        rows, cols = rows[pick], cols[pick]
    ref = frame_reference(x)
    k = len(names)
    return {"pixels": feats[3:, rows, cols].copy(), "y": gt[rows, cols].astype(np.float32),
            "rows": rows.astype(np.int32), "cols": cols.astype(np.int32),
            "grid": context_grid(x, feats[3:3 + k], ref), "ref": np.float32(ref), "width": gt.shape[1]}


class ContextBlendInpainter(BlendInpainter):
    """Learned per-pixel blend of classical fills, with scene context from a small U-Net.

    Parameters
    ----------
    candidates : tuple of str, default :data:`~estimators.learned._blend.BLEND_CANDIDATES`
        Classical fills the blend chooses between.
    n_context : int, default 8
        Context features per pixel.
    context_widths : tuple of int, default (16, 32, 48, 64)
        Channels per level of the context U-Net (on the 1/8-scale grid).
    width, layers : int, default 64, 2
        Hidden units and layers of the per-pixel MLP.
    residual : bool, default True
        Add a learned scale-free residual to the blend.
    n_members : int, default 1
        Networks trained on the same samples from different seeds (member 0 from the
        estimator's seed, so it is the network ``n_members=1`` trains); ``predict``
        averages them. Each member costs one more training run and one more network
        pass per prediction; the candidate features are computed once.
    member_samples : {"shared", "own"}, default "shared"
        Training samples of the members: ``"shared"`` draws one set (occlusions, thinning,
        pixels) that every member trains on; ``"own"`` gives member ``m`` its own draw from
        its own seed, so the members differ in the occlusions they learn from as well as
        in initialisation (member 0's draw is the one ``n_members=1`` makes). ``"own"``
        computes the samples once per member.
    keep : tuple of float, default (1.0, 0.6)
        Training inputs per occlusion: fractions of the measured pixels kept outside
        the hole (0.6 is about as sparse as KITTI's official maps).
    masks_per_frame : int, default 3
        Occlusions drawn per training frame.
    pixels_per_frame : int, default 3000
        Hole pixels with ground truth kept per sample.
    balance : float, default 1.0
        Samples are drawn with weight ``1 / (samples of their drive) ** balance``: 1
        gives every drive the same share, 0 every sample.
    epochs : int, default 4
        Passes, in samples drawn, over the training samples.
    batch_frames, batch_pixels : int, default 8, 1024
        Samples per step and pixels drawn from each.
    lr : float, default 2e-3
        Peak learning rate (one-cycle, Adam).
    protocol : str, default "rect-v1"
        Occlusion protocol of training.
    tta : bool, default True
        Average with the mirrored frame's prediction (context included).
    random_state : int, RandomState, Generator or None, default 0
        Seeds occlusions, sampling, thinning, initialisation and batch order.
    num_threads, predict_threads : int or None, default None, 1
        torch threads while fitting and predicting (None: leave torch's setting).
    n_jobs : int, optional
        Frames whose training samples are computed in parallel (joblib threads).
    keep_observed : bool, default True
        Return measured input pixels unchanged.
    verbose : bool or int, default False
        Progress of ``fit`` when true or > 0 (as scikit-learn's ``verbose``): a bar on a
        terminal, one line per epoch in a log.

    Attributes
    ----------
    model_ : ContextBlendNet
    history_ : dict
        ``epoch_loss``: mean training MSE (m²) per epoch.
    n_samples_, n_pixels_ : int
        Training samples (frame, occlusion, keep) and pixels, over every member's own
        draw with ``member_samples="own"``.
    training_frames_ : int
        Frames with ground truth used.
    fit_seconds_ : float
        Wall-clock time of ``fit``.
    """

    def __init__(
        self,
        *,
        candidates: tuple[str, ...] = BLEND_CANDIDATES,
        n_context: int = 8,
        context_widths: tuple[int, ...] = (16, 32, 48, 64),
        width: int = 64,
        layers: int = 2,
        residual: bool = True,
        n_members: int = 1,
        member_samples: str = "shared",
        keep: tuple[float, ...] = (1.0, 0.6),
        masks_per_frame: int = 3,
        pixels_per_frame: int = 3000,
        balance: float = 1.0,
        epochs: int = 4,
        batch_frames: int = 8,
        batch_pixels: int = 1024,
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
        self.n_context = n_context
        self.context_widths = context_widths
        self.width = width
        self.layers = layers
        self.residual = residual
        self.n_members = n_members
        self.member_samples = member_samples
        self.keep = keep
        self.masks_per_frame = masks_per_frame
        self.pixels_per_frame = pixels_per_frame
        self.balance = balance
        self.epochs = epochs
        self.batch_frames = batch_frames
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

    # The blend's parameter checks read these; the context model is always relative,
    # always reads endpoints and keeps every sampled pixel.
    endpoints = True
    relative = True
    max_pixels = None
    _TUPLE_PARAMS = ("candidates", "keep", "context_widths")

    _parameter_constraints = {
        # endpoints, relative and max_pixels are fixed by the class above, not parameters.
        **{k: v for k, v in BlendInpainter._parameter_constraints.items()
           if k not in ("endpoints", "relative", "max_pixels")},
        "n_context": [Integer(1, limit=MAX_WIDTH)],
        "context_widths": [Sequence(Integer(1), max_len=MAX_LAYERS, max_item=MAX_WIDTH)],
        "balance": [Real(0, 1)],
        "batch_frames": [Integer(1)],
        "n_members": [Integer(1, limit=MAX_MEMBERS)],
        "member_samples": [Options("shared", "own")],
    }

    def _model_params(self) -> dict[str, Any]:
        params = {"candidates": list(self.candidates), "n_context": int(self.n_context),
                  "context_widths": [int(w) for w in self.context_widths], "width": int(self.width),
                  "layers": int(self.layers), "residual": bool(self.residual)}
        if int(self.n_members) > 1:  # absent for one network, as in releases made before ensembles
            params["n_members"] = int(self.n_members)
        return params

    def _build_net(self) -> ContextBlendNet:
        return ContextBlendNet(len(self.candidates), int(self.n_context), [int(w) for w in self.context_widths],
                               int(self.width), int(self.layers), residual=bool(self.residual))

    def _build_model(self) -> ContextBlendNet | ContextBlendEnsemble:
        if int(self.n_members) == 1:
            return self._build_net()
        return ContextBlendEnsemble([self._build_net() for _ in range(int(self.n_members))])

    def _networks(self) -> list[ContextBlendNet]:
        """The fitted network, or the ensemble's members."""
        return list(self.model_.members) if isinstance(self.model_, ContextBlendEnsemble) else [self.model_]

    # -- fitting ---------------------------------------------------------------------------
    def _fit(self, dataset: DepthDataset) -> None:
        self._check_params()
        self._check_size()
        start = time.perf_counter()
        seed = resolve_seed(self.random_state)
        samples, groups = self.training_samples(dataset, seed=seed)
        if not samples:
            raise InvalidInputError("no training frame has ground truth inside its sampled holes; nothing to learn")
        with torch_threads(self.num_threads), deterministic_torch():
            self.fit_environment_ = environment_info(torch_details=True)
            self.model_, self.history_ = self._train(dataset, samples, groups, seed)
        self.seed_ = seed
        self.model_params_ = self._model_params()
        self.fit_seconds_ = time.perf_counter() - start

    def training_samples(self, dataset: DepthDataset, seed: int | None = None) -> tuple[list[dict], list[str]]:
        """Training samples (see :func:`training_sample`) and the drive of each.

        Frame ``i`` gets ``masks_per_frame`` occlusions from its own random stream
        (``seed``, ``i``), independent of the evaluation masks, and one input per
        ``keep`` fraction. Samples without ground truth in their hole are left out.
        """
        if seed is None:
            seed = resolve_seed(self.random_state)
        protocol = get_protocol(self.protocol)
        names = tuple(self.candidates)
        groups = list(getattr(dataset, "groups", None) if getattr(dataset, "groups", None) is not None
                      else ["all"] * len(dataset))

        def one_frame(i: int) -> list[dict]:
            gt = check_depth(dataset[i], name=f"training frame {frame_label(dataset, i)}", ndim=(2,))
            if not (gt > 0).any():
                return []
            rng = np.random.default_rng([int(seed), i, 0xC0E7])
            out = []
            for _ in range(int(self.masks_per_frame)):
                hole = protocol.sample(gt.shape, rng)
                out += [training_sample(gt, hole, float(k), int(self.pixels_per_frame), names, rng) for k in self.keep]
            return [s for s in out if len(s["y"])]

        per_frame = self._map_frames(one_frame, len(dataset), "training samples")
        self.training_frames_ = sum(1 for f in per_frame if f)
        samples, sample_groups = [], []
        for i, frame in enumerate(per_frame):
            samples += frame
            sample_groups += [str(groups[i])] * len(frame)
        return samples, sample_groups

    def _train(self, dataset: DepthDataset, samples: list[dict], groups: list[str],
               seed: int) -> tuple[nn.Module, dict]:
        """Train ``n_members`` fresh networks: member 0 from ``seed`` on ``samples``, the others
        from seeds derived from it, on the same samples or (``member_samples="own"``) on
        samples drawn from their own seed."""
        n = int(self.n_members)
        seeds = [seed] + [int(s) for s in np.random.SeedSequence([seed, 0xE75]).generate_state(n - 1)]
        trained = []
        self.n_samples_, self.n_pixels_ = 0, 0
        for m, member_seed in enumerate(seeds):
            if self.verbose and n > 1:
                print(f"member {m + 1}/{n} (seed {member_seed})", flush=True)
            if m > 0 and self.member_samples == "own":
                frames = self.training_frames_
                samples = groups = None  # drop the previous own draw before the next (the caller keeps member 0's)
                samples, groups = self.training_samples(dataset, seed=member_seed)
                self.training_frames_ = max(frames, self.training_frames_)
            if m == 0 or self.member_samples == "own":
                self.n_samples_ += len(samples)
                self.n_pixels_ += int(sum(len(s["y"]) for s in samples))
            trained.append(self._train_network(samples, groups, member_seed))
        if n == 1:
            return trained[0]
        history = {"epoch_loss": trained[0][1]["epoch_loss"], "member_epoch_loss": [h["epoch_loss"] for _, h in trained]}
        return ContextBlendEnsemble([net for net, _ in trained]).eval(), history

    def _train_network(self, samples: list[dict], groups: list[str], seed: int) -> tuple[ContextBlendNet, dict]:
        """Train one fresh network on the samples through :func:`~._loop.fit_loop`, drives weighted by ``balance``."""
        net = seeded(self._build_net, seed)
        rng = np.random.default_rng([seed, 0x5EED])
        counts: dict[str, int] = {}
        for g in groups:
            counts[g] = counts.get(g, 0) + 1
        weights = np.array([counts[g] ** -float(self.balance) for g in groups])
        weights /= weights.sum()
        batch = min(int(self.batch_frames), len(samples))
        per_epoch = max(1, len(samples) // batch)
        optimisation = Optimisation(net, self.lr, schedule=OneCycle(self.lr, per_epoch * int(self.epochs)))
        mirrored = net.mirror_order()

        def epoch_batches(epoch: int, done: int) -> Any:
            for _ in range(per_epoch):
                yield rng.choice(len(samples), batch, replace=False, p=weights)

        def step(picks: np.ndarray) -> float:
            flip = bool(rng.random() < 0.5)  # mirror augmentation: the mirrored frame's samples
            return optimisation.update(lambda: self._batch_loss(net, [samples[k] for k in picks], rng, flip, mirrored))

        net.train()
        progress = fit_loop(new_progress(), epoch_batches, step, epochs=int(self.epochs), steps_per_epoch=per_epoch,
                            desc=type(self).__name__, verbose=bool(self.verbose))
        net.eval()
        return net, {"epoch_loss": progress["history"]["epoch_loss"]}

    def _batch_loss(self, net: ContextBlendNet, batch: list[dict], rng: np.random.Generator, flip: bool,
                    mirrored: list[int]) -> torch.Tensor:
        grids = torch.from_numpy(np.stack([s["grid"] for s in batch]))
        if flip:
            grids = grids.flip(-1)
        context = net.context(grids)
        preds, truths = [], []
        for n, s in enumerate(batch):
            m = len(s["y"])
            sel = rng.choice(m, int(self.batch_pixels), replace=False) if m > self.batch_pixels else np.arange(m)
            pixels = torch.from_numpy(s["pixels"][:, sel])
            cols = torch.from_numpy(s["cols"][sel])
            if flip:
                pixels, cols = pixels[mirrored], s["width"] - 1 - cols
            ctx = net.sample(context[n], torch.from_numpy(s["rows"][sel]), cols)
            preds.append(net.blend_pixels(pixels, ctx, float(s["ref"])))
            truths.append(torch.from_numpy(s["y"][sel]))
        return (torch.cat(preds) - torch.cat(truths)).square().mean()

    # -- prediction ------------------------------------------------------------------------
    def _predict_features(self, frame: np.ndarray, feats: np.ndarray) -> np.ndarray:
        k = len(self.candidates)
        out = feats[0].copy()
        known = feats[2] > 0.5
        cands = feats[3:3 + k]
        out[~known] = cands[:, ~known].mean(axis=0)  # unmeasured pixels outside holes: candidates' mean
        hole = feats[1] > 0.5
        if not hole.any():
            return out
        ref = frame_reference(frame)
        grid = torch.from_numpy(context_grid(frame, cands, ref))[None]
        rows_np, cols_np = np.nonzero(hole)
        rows, cols = torch.from_numpy(rows_np), torch.from_numpy(cols_np)
        channels = torch.from_numpy(np.ascontiguousarray(feats[3:, rows_np, cols_np]))
        passes = [(grid, cols, None)]
        if self.tta:
            passes.append((grid.flip(-1), frame.shape[1] - 1 - cols, self.model_.mirror_order()))
        nets = self._networks()
        total = torch.zeros(len(rows_np))
        for net in nets:
            for g, c, order in passes:
                context = net.context(g)[0]
                ch = channels if order is None else channels[order]
                values = [net.blend_pixels(ch[:, a:a + CHUNK].contiguous(),
                                           net.sample(context, rows[a:a + CHUNK], c[a:a + CHUNK]), ref)
                          for a in range(0, len(rows_np), CHUNK)]
                total += torch.cat(values)
        pred = total / (len(passes) * len(nets))
        # floor at half the smallest candidate, as the blend does (see pixel_blend.fill_holes)
        floor = 0.5 * torch.from_numpy(cands[:, rows_np, cols_np]).min(dim=0).values
        out[rows_np, cols_np] = torch.maximum(pred, floor).numpy()
        return out


# estimators.learned.load finds classes by the name a checkpoint records.
