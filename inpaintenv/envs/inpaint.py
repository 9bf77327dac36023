"""``DepthInpaintEnv``: one occluded frame per episode, scored on the submitted reconstruction.

Episode = one frame:

* ``reset(seed=..., options={"index": i, "mask_seed": s})`` picks frame ``i`` (drawn from
  the env's generator when absent) and draws its occlusion as
  ``protocol.mask(frame_shape, s, i)`` -- the very mask :func:`inpaintenv.evaluate`
  uses for evaluation seed ``s`` (``s`` drawn from the env's generator when absent).
* ``step(reconstruction)`` scores the ``(H, W)`` reconstruction in metres with the
  metrics of :func:`inpaintenv.metrics.frame_metrics` (through the
  :class:`~inpaintenv.metrics.ScoredPixels` gathered at ``reset``, so a step reads only
  the action); reward = −hole RMSE (−unmeasured RMSE under ``densify-v1``), ``terminated=True``.
* The input is the dataset's ``input_kind`` (:mod:`inpaintenv.data.inputs`): the frame
  itself, or a single LiDAR scan of it whose ground truth is only the target.

Decisions (see ``docs/env.md``):

* **Holes without ground truth.** If the drawn hole holds no valid ground-truth pixel,
  the mask is redrawn deterministically from ``(protocol, mask_seed, index, attempt)``,
  at most :data:`MAX_MASK_REDRAWS` times (``info["mask_redraws"]`` says how many). A
  frame with no ground truth under any of those masks is refused: a randomly drawn index
  is replaced by another random frame (at most :data:`MAX_FRAME_DRAWS` tries); an index
  given in ``options`` raises ``ValueError``. So every step has a defined reward.
* **Bad actions raise**, they are never scored with a penalty: a non-array or non-float
  dtype raises ``TypeError``; a wrong shape, NaN/inf, negative depth or depth above the
  action space's bound raises ``ValueError``, and so does an action left at 0 m at a
  hole pixel with ground truth (unfilled) unless ``unfilled`` says how to score it, as in
  :func:`inpaintenv.evaluate.evaluate`. A penalty would hide bugs in a method behind a
  bad but plausible score.
"""

from __future__ import annotations

import zlib
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from ..conventions import (
    DEFAULT_MAX_DEPTH,
    DEPTH_LIMIT,
    as_depth_array,
    check_int,
    check_max_depth,
    in_depth_range,
    reconstruction_problem,
)
from ..data.base import DepthDataset, as_dataset
from ..data.inputs import check_input_kind
from ..masks import OcclusionProtocol, get_protocol
from ..metrics import CALIBRATION_LEVELS, FrameBatch, as_coverage, computed_metrics, interval_from_std, interval_metrics
from ..metrics import ScoredPixels, check_unfilled
from .render import render_panel
from ..exceptions import InvalidInputError, StateError

__all__ = ["DEPTH_LIMIT", "MAX_FRAME_DRAWS", "MAX_MASK_REDRAWS", "DepthInpaintEnv", "draw_scored_hole"]

# DEPTH_LIMIT (from conventions) bounds the depth spaces: the largest depth KITTI's
# 16-bit PNG encoding can hold (65535 / 256 m). Gymnasium's checker needs finite bounds.
#: Redraws of a mask whose hole holds no valid ground truth.
MAX_MASK_REDRAWS = 16
#: Random frames tried when a frame has no valid ground truth under any redraw.
MAX_FRAME_DRAWS = 64
#: Largest mask seed drawn by the env (exclusive).
MASK_SEED_HIGH = 2**31


def draw_scored_hole(
    protocol: OcclusionProtocol, gt: np.ndarray, mask_seed: int, index: int,
    max_redraws: int = MAX_MASK_REDRAWS, inputs: np.ndarray | None = None,
) -> tuple[np.ndarray | None, int]:
    """The first mask of ``(protocol, mask_seed, index)`` whose hole holds valid ground truth.

    Attempt 0 is ``protocol.mask(gt.shape, mask_seed, index)``; attempt ``k > 0`` draws from
    ``SeedSequence([crc32(name), mask_seed, index, k])``, so redraws are reproducible too.
    Under a protocol whose task is ``"unmeasured"`` (``densify-v1``) the pixels that must
    hold ground truth are the hole and every pixel the measured ``inputs`` lack (``inputs``:
    a scan, 0 = not measured; by default ``gt`` itself).

    Returns
    -------
    hole : numpy.ndarray or None
        ``(H, W)`` bool, or None when no attempt covers a valid pixel.
    redraws : int
        Number of masks rejected before ``hole``.
    """
    valid = gt > 0
    # With a scan, a task on the unmeasured pixels also scores the truth the scan lacks.
    lacking = bool((valid & (inputs == 0)).any()) if protocol.task == "unmeasured" and inputs is not None else False
    for attempt in range(max_redraws + 1):
        if attempt == 0:
            hole = protocol.mask(gt.shape, mask_seed, index)
        else:
            ss = np.random.SeedSequence([zlib.crc32(protocol.name.encode()), mask_seed, index, attempt])
            hole = protocol.sample(gt.shape, np.random.default_rng(ss))
        if lacking or (hole & valid).any():
            return hole, attempt
    return None, max_redraws + 1


class DepthInpaintEnv(gym.Env):
    """Gymnasium env: fill the occluded part of one depth frame per episode.

    Parameters
    ----------
    dataset : DepthDataset or array-like
        Ground truth (``(N, H, W)`` metres, 0 = no measurement); arrays are wrapped.
    protocol : str or OcclusionProtocol
        Occlusion protocol, ``"rect-v1"`` by default.
    max_depth : float
        Range of PSNR and of the render colour scale, metres: finite, in
        ``(0, DEPTH_LIMIT]``.
    render_mode : {None, "rgb_array"}
    unfilled : {"error", "interpolate", "zero"}
        An action of 0 m at a hole pixel with ground truth is refused (``ValueError`` counting
        the pixels; the default), filled first by the KITTI devkit's background
        interpolation, or scored as 0 m, as in :func:`inpaintenv.evaluate.evaluate`.
    interval_coverage : float
        Nominal coverage (in (0, 1), 0.9 by default) of the interval a ``std`` action
        stands for: ``[depth - z·std, depth + z·std]`` clipped at 0 m, ``z`` its normal quantile.
    input : {"map", "scan"}, optional
        The input kind, which the dataset decides (:mod:`inpaintenv.data.inputs`); given,
        it must be the dataset's (a map source has no scans).

    Observation
    -----------
    ``{"depth": float32 (H, W), "hole": uint8 (H, W), "measured": uint8 (H, W)}``: the
    input with the hole zeroed (for a map input the ground truth itself, for a scan input
    the scan; 0 means "occluded" in the hole, elsewhere "no measurement"), the hole mask
    (1 = occluded), and where the input holds a measurement after the hole was cut
    (``depth > 0``; every other pixel with ground truth is scored as unmeasured). All are
    ``Box`` spaces with finite bounds ``[0, DEPTH_LIMIT]`` and ``[0, 1]``.

    Action
    ------
    float ``(H, W)`` reconstruction in metres, ``Box(0, DEPTH_LIMIT)``. Every pixel must
    be finite; only pixels with ground truth are scored. A submission may also carry a
    per-pixel interval: ``step`` then takes a dict ``{"depth": reconstruction, "low":
    low, "high": high}`` or ``{"depth": reconstruction, "std": std}`` (float ``(H, W)``
    metres each; in the hole finite with ``0 <= low <= depth <= high``, ``std >= 0``).
    The action space stays the plain ``Box``: the dict is an extension ``step`` accepts,
    and a plain array is scored as before.

    Reward and info
    ---------------
    ``step`` returns reward = −hole RMSE (metres; −unmeasured RMSE under a protocol whose
    ``task`` is ``"unmeasured"``, ``densify-v1``), ``terminated=True``,
    ``truncated=False``, and ``info`` with every metric of
    :func:`~inpaintenv.metrics.frame_metrics` (``hole_rmse``, ..., ``all_count``, the
    ``unmeasured_*`` and ``kitti_*`` ones) as Python numbers, plus ``frame_id``, ``drive``,
    ``index``, ``mask_seed``, ``mask_redraws``, ``hole_fraction`` and ``input_kind``; a
    metric undefined in the episode (the hole's under ``densify-v1``, whose hole is empty:
    ``hole_count`` is 0) is left out. ``reset`` returns the same episode keys.
    With an interval, ``info`` also has the columns of
    :data:`~inpaintenv.metrics.INTERVAL_COLUMNS` (``hole_coverage``,
    ``hole_interval_width``, ``rmse_keep_80``, ...) and of the metric records computed
    from their own record (per-image ``ause_rmse``, ``aurg_rmse``, ``auce`` and the coverage at
    each level, the last two from a ``std`` action only) as floats; the reward is unchanged.
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["rgb_array"], "render_fps": 4}

    def __init__(
        self,
        dataset: Any,
        protocol: str | OcclusionProtocol = "rect-v1",
        max_depth: float = DEFAULT_MAX_DEPTH,
        render_mode: str | None = None,
        unfilled: str = "error",
        interval_coverage: float = 0.9,
        input: str | None = None,
    ):
        self.dataset: DepthDataset = as_dataset(dataset)
        if len(self.dataset) == 0:
            raise InvalidInputError("the dataset has no frames")
        if input is not None and check_input_kind(input) != self.dataset.input_kind:
            raise InvalidInputError(f"input={input!r}, but the dataset's input kind is {self.dataset.input_kind!r}; "
                                    "open the source with that input (e.g. KittiDepth(..., input='scan'))")
        self.input_kind = self.dataset.input_kind
        self.protocol = get_protocol(protocol)
        max_depth = check_max_depth(max_depth)
        if max_depth > DEPTH_LIMIT:
            raise InvalidInputError(f"max_depth must be in (0, {DEPTH_LIMIT}], got {max_depth}")
        self.max_depth = max_depth
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise InvalidInputError(
                f"render_mode must be None or one of {self.metadata['render_modes']}, got {render_mode!r}"
            )
        self.render_mode = render_mode
        self.unfilled = check_unfilled(unfilled)
        self.interval_coverage = as_coverage(interval_coverage, "interval_coverage")
        shape = tuple(int(s) for s in self.dataset.frame_shape)
        self.frame_shape: tuple[int, int] = shape  # type: ignore[assignment]
        self.observation_space = spaces.Dict(
            {
                "depth": spaces.Box(0.0, DEPTH_LIMIT, shape=shape, dtype=np.float32),
                "hole": spaces.Box(0, 1, shape=shape, dtype=np.uint8),
                "measured": spaces.Box(0, 1, shape=shape, dtype=np.uint8),
            }
        )
        self.action_space = spaces.Box(0.0, DEPTH_LIMIT, shape=shape, dtype=np.float32)
        self._gt: np.ndarray | None = None
        self._hole: np.ndarray | None = None
        self._pred: np.ndarray | None = None
        self._obs_depth: np.ndarray | None = None
        self._scored: ScoredPixels | None = None
        self._episode: dict[str, Any] = {}
        self._metrics: dict[str, Any] | None = None
        self._done = True

    # -- episode ---------------------------------------------------------------------
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Start an episode on one frame.

        Parameters
        ----------
        seed : int, optional
            Seeds the env's generator (which draws the index and mask seed when absent).
            Gymnasium itself refuses a negative or non-int seed (``gymnasium.error.Error``).
        options : dict, optional
            ``"index"``: frame index; ``"mask_seed"``: seed of the mask, so that
            ``options={"index": i, "mask_seed": s}`` serves exactly the pair
            :func:`inpaintenv.evaluate` scores for frame ``i`` under seed ``s``.

        Returns
        -------
        observation : dict
        info : dict
        """
        super().reset(seed=seed)
        options = dict(options or {})
        unknown = set(options) - {"index", "mask_seed"}
        if unknown:
            raise InvalidInputError(f"unknown reset options {sorted(unknown)}; known: 'index', 'mask_seed'")
        index = options.get("index")
        mask_seed = options.get("mask_seed")
        if index is not None:
            index = check_int(index, "options['index']", upper=len(self.dataset))
        if mask_seed is not None:
            mask_seed = check_int(mask_seed, "options['mask_seed']")

        tries = 1 if index is not None else MAX_FRAME_DRAWS
        for _ in range(tries):
            i = index if index is not None else int(self.np_random.integers(len(self.dataset)))
            s = mask_seed if mask_seed is not None else int(self.np_random.integers(MASK_SEED_HIGH))
            inputs, gt = self._load(i)
            hole, redraws = draw_scored_hole(self.protocol, gt, s, i, inputs=None if inputs is gt else inputs)
            if hole is not None:
                break
        if hole is None and index is not None:
            raise InvalidInputError(
                f"frame {i} ({self.dataset.frame_ids[i]}) has no valid ground truth inside any of "
                f"{MAX_MASK_REDRAWS + 1} {self.protocol.name} masks, so no reconstruction could "
                "be scored; choose another index"
            )
        if hole is None:
            raise StateError(
                f"{MAX_FRAME_DRAWS} random frames had no valid ground truth inside any "
                f"{self.protocol.name} hole; does the dataset hold any measurement?"
            )
        # Only render() reads the frame after reset: keep a copy only then (an array
        # dataset hands out views of the caller's array).
        self._gt = np.array(gt, copy=True) if self.render_mode is not None else None
        self._hole, self._pred, self._metrics = hole, None, None
        # Built once per episode: reset hands out a copy, step the original (see step).
        depth = inputs.copy()
        np.copyto(depth, np.float32(0.0), where=hole)  # cheaper than np.where's select
        self._obs_depth = depth
        # Ground truth and hole are gathered here, so step reads only the action. All
        # were checked above (checked_frame or load_pairs, the protocol's own bool mask).
        self._scored = ScoredPixels(gt, hole, inputs=None if inputs is gt else inputs, check_input=False)
        self._episode = {
            "frame_id": str(self.dataset.frame_ids[i]),
            "drive": str(self.dataset.groups[i]),
            "index": i,
            "mask_seed": s,
            "mask_redraws": redraws,
            "hole_fraction": np.count_nonzero(hole) / hole.size,
            "input_kind": self.input_kind,
        }
        self._done = False
        return self._observation(depth.copy()), dict(self._episode)

    def step(
        self, action: Any
    ) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        """Score a reconstruction of the current frame; the episode ends.

        Raises
        ------
        TypeError
            If ``action`` is not a plain floating-point array (integer, masked, sparse).
        ValueError
            On a wrong shape, NaN/inf, negative depth, depth above ``DEPTH_LIMIT``, or
            (``unfilled="error"``) 0 m at a hole pixel with ground truth.
        RuntimeError
            If called before ``reset`` or after the episode ended.
        """
        if self._done or self._scored is None or self._obs_depth is None or self._hole is None:
            raise StateError("the episode is over or has not started; call reset() first")
        action, bounds = self._split_action(action)
        pred = self._check_action(action)
        m = self._scored.metrics(pred, max_depth=self.max_depth, unfilled=self.unfilled)
        # A metric undefined here (NaN: the hole's under densify-v1, whose hole is empty) is left out.
        metrics = {k: (int(v) if k.endswith("_count") else float(v)) for k, v in m.items() if not np.isnan(v)}
        if bounds is not None:
            metrics.update(self._interval_info(pred, bounds))
        metrics.update(self._computed_info(pred, bounds))
        # Only render() reads the reconstruction later: copy it only then (the caller's
        # array is never kept, and a 352x1216 copy per step is not free).
        self._pred = np.array(pred, dtype=np.float32, copy=True) if self.render_mode is not None else None
        self._metrics = metrics
        self._done = True
        info = {**metrics, **self._episode}
        # Every call returns fresh arrays (callers may keep or modify them). The episode
        # is over, so the env's own depth observation is handed over instead of copied;
        # the hole is copied since render() still reads it.
        obs = self._observation(self._obs_depth)
        self._obs_depth = None
        return obs, -metrics[f"{self.protocol.task}_rmse"], True, False, info

    def render(self) -> np.ndarray | None:
        """The RGB uint8 panel of the current frame (``render_mode="rgb_array"``), else None."""
        if self.render_mode != "rgb_array" or self._gt is None or self._hole is None:
            return None
        title = None
        if self._metrics is not None:
            m = self._metrics
            title = (
                f"{self._episode['frame_id']}  {self.protocol.task} RMSE {m[self.protocol.task + '_rmse']:.3f} m  "
                f"PSNR {m[self.protocol.task + '_psnr']:.2f} dB | all RMSE {m['all_rmse']:.3f} m  PSNR {m['all_psnr']:.2f} dB"
            )
        return render_panel(self._gt, self._hole, self._pred, max_depth=self.max_depth, title=title)

    # -- helpers ---------------------------------------------------------------------
    def _observation(self, depth: np.ndarray) -> dict[str, np.ndarray]:
        """The observation of ``depth``, the input with the hole zeroed (fresh masks)."""
        assert self._hole is not None
        return {"depth": depth, "hole": self._hole.astype(np.uint8), "measured": (depth > 0).view(np.uint8)}

    def _load(self, index: int) -> tuple[np.ndarray, np.ndarray]:
        """``(input, ground truth)`` of frame ``index``; the input *is* the frame for a map source."""
        # The checks also refuse depth above DEPTH_LIMIT, the observation space's bound.
        # No copy: reset builds its own observation and scored pixels from the frame.
        if self.dataset.input.is_map:
            gt = self.dataset.checked_frame(index, f"frame {index}")
            return gt, gt
        inputs, gt = self.dataset.load_pairs([index])
        return inputs[0], gt[0]

    def _split_action(self, action: Any) -> tuple[Any, dict[str, Any] | None]:
        """``(reconstruction, interval entries or None)`` of a plain or dict action."""
        if not isinstance(action, dict):
            return action, None
        keys = set(action)
        if keys not in ({"depth", "low", "high"}, {"depth", "std"}):
            raise InvalidInputError(f"a dict action has the keys 'depth', 'low', 'high' or 'depth', 'std'; "
                                    f"got {sorted(map(str, keys))}")
        return action["depth"], {k: v for k, v in action.items() if k != "depth"}

    def _interval_info(self, pred: np.ndarray, bounds: dict[str, Any]) -> dict[str, float]:
        """The interval columns of ``info`` for the checked reconstruction ``pred``."""
        assert self._scored is not None and self._hole is not None
        if "std" in bounds:
            low, high = interval_from_std(pred, bounds["std"], self.interval_coverage)
        else:
            low, high = bounds["low"], bounds["high"]
        # The ground truth, rebuilt from the pixels gathered at reset (the frame itself is not kept).
        gt = np.zeros(self.frame_shape, dtype=np.float32)
        gt.reshape(-1)[self._scored._index] = self._scored._gt
        return {k: float(v) for k, v in interval_metrics(pred, gt, self._hole, low, high).items()}

    def _computed_info(self, pred: np.ndarray, bounds: dict[str, Any] | None) -> dict[str, float]:
        """The metric records computed from their own record (AUSE, AURG, AUCE, ...): as ``evaluate`` gives them.

        The reliability diagram needs the interval at every level: from a ``std`` action; an
        action's ``low``/``high`` is one level only, so the figures that need the others are left out.
        """
        assert self._scored is not None and self._hole is not None and self._obs_depth is not None
        gt = np.zeros(self.frame_shape, dtype=np.float32)
        gt.reshape(-1)[self._scored._index] = self._scored._gt
        low = high = levels = None
        if bounds is not None:
            if "std" in bounds:
                levels = {c: tuple(b[None] for b in interval_from_std(pred, bounds["std"], c))
                          for c in CALIBRATION_LEVELS}
                low, high = (b[None] for b in interval_from_std(pred, bounds["std"], self.interval_coverage))
            else:
                low, high = (np.asarray(bounds[k], dtype=np.float64)[None] for k in ("low", "high"))
        batch = FrameBatch(pred[None], gt[None], self._hole[None], np.asarray(self._obs_depth)[None], low, high, levels)
        return {k: float(v[0]) for k, v in computed_metrics(batch).items() if not np.isnan(v[0])}

    def _check_action(self, action: Any) -> np.ndarray:
        # The package's one input rule: a plain float array (masked arrays, integers,
        # sparse matrices are refused as everywhere else).
        arr = as_depth_array(action, "action")
        if arr.shape != self.frame_shape:
            raise InvalidInputError(f"action has shape {arr.shape}, expected {self.frame_shape}")
        # Checked as the action space holds it: float64 values are rounded to float32
        # first. The rule is every scored reconstruction's (evaluate and the metrics too).
        with np.errstate(over="ignore"):
            arr32 = arr.astype(np.float32, copy=False)
        if in_depth_range(arr32):  # two reductions settle the common case
            return arr32
        raise InvalidInputError(f"action {reconstruction_problem(arr)}")
