"""Named training recipes, e.g. ``cpu-1h``: the shipped model's recipe, reproducible on a laptop.

>>> from estimators.presets import train_preset, PRESETS              # doctest: +SKIP
>>> est = train_preset("cpu-1h", KittiDepth(root, split="train", drives=[...]))
>>> est.save("my-model")

The CLI's ``inpaintenv train --preset NAME`` calls :func:`train_preset`.
"""

from __future__ import annotations

import copy
import inspect
import os
import time
from typing import Any

from .blend import BlendInpainter
from .context_blend import ContextBlendInpainter
from .ensemble import MeanEnsembleInpainter
from .neural import AutoencoderInpainter, UNetInpainter
from .prior import PriorUNetInpainter

__all__ = ["PRESETS", "STAGED_PRESETS", "available_presets", "check_preset", "describe_preset", "make_preset",
           "preset_checkpoints", "preset_runs_joblib", "train_preset"]

#: The CPU-budget configuration shared by the study's variants below.
_STUDY_CPU: dict[str, Any] = dict(
    width=16, depth=4, crop=(176, 416), batch_size=4, max_steps=1000, epochs=10_000,
    hole_weight=2.0, random_state=0,
)

#: kitti-rect-v2's recipe, the base of the later releases: six candidates, 900 steps, one thread.
_BLEND_V2: dict[str, Any] = dict(
    arch="pixel", width=128, levels=3, pixel_batches=8, batch_size=4, lr=2e-3, max_steps=900, epochs=10_000,
    candidates=("scanline", "scanline-inverse", "vertical", "harmonic", "vertical-inverse", "harmonic-inverse"),
    flip=True, tta=True, num_threads=1, random_state=0,
)

#: kitti-rect-v4's recipe (BlendInpainter): chosen by leave-one-drive-out cross-validation
#: on the train drives (experiments/blend_lodo.py; docs/reference/selection.md).
_BLEND_V4: dict[str, Any] = dict(
    candidates=("scanline", "scanline-inverse", "vertical", "vertical-inverse", "harmonic-inverse"),
    endpoints=True, width=64, layers=2, relative=True, residual=True, keep=(1.0, 0.65, 0.4), masks_per_frame=3,
    pixels_per_frame=3000, epochs=3, batch_pixels=8192, lr=2e-3, protocol="rect-v1", tta=True, random_state=0,
    num_threads=2, n_jobs=2,
)

#: kitti-context-v1's recipe (ContextBlendInpainter): chosen by leave-one-day-out and
#: leave-drive-0001-out cross-validation (experiments/context_blend.py; docs/reference/selection.md).
_CONTEXT_V1: dict[str, Any] = dict(
    candidates=("scanline", "scanline-inverse", "vertical", "vertical-inverse", "harmonic-inverse"),
    n_context=8, context_widths=(16, 32, 48, 64), width=64, layers=2, residual=True, keep=(1.0, 0.6),
    masks_per_frame=3, pixels_per_frame=3000, balance=1.0, epochs=4, batch_frames=8, batch_pixels=1024, lr=2e-3,
    protocol="rect-v1", tta=True, random_state=0, num_threads=2, n_jobs=2,
)

#: kitti-context-v2's recipe: kitti-context-v1's, two networks from different seeds averaged,
#: without the mirrored second pass (it changed no fold by more than 0.003; the second
#: network costs what the mirrored pass did). experiments/context_blend.py --ensemble;
#: docs/reference/selection.md.
_CONTEXT_V2: dict[str, Any] = {**_CONTEXT_V1, "n_members": 2, "tta": False}

#: kitti-context-v2's recipe with each network trained on its own draw of occlusions,
#: thinning and pixels (member_samples="own"): the run-to-run spread of one recipe on a
#: fold follows the sample draw more than the initialisation, and v2's members share one.
#: The shipped kitti-context-v3 (docs/model_cards/kitti-context-v3.md).
_CONTEXT_DRAWS: dict[str, Any] = {**_CONTEXT_V2, "member_samples": "own"}

#: The mean of kitti-context-v3's recipe and kitti-rect-v4's without its mirrored pass
#: (the features are shared, the mirrored pass was the blend's own cost; it moved no fold's
#: ratio by more than 0.002): experiments/nested_mean.py, docs/reference/selection.md.
_ENSEMBLE_V1: dict[str, Any] = dict(estimators=[
    ("context", ContextBlendInpainter(**_CONTEXT_DRAWS)),
    ("blend", BlendInpainter(**{**_BLEND_V4, "tta": False})),
])

#: name -> (estimator class, constructor keywords, one-line description).
PRESETS: dict[str, tuple[type, dict[str, Any], str]] = {
    # the mean of kitti-context-v3's recipe and kitti-rect-v4's.
    "ensemble-kitti": (
        MeanEnsembleInpainter, _ENSEMBLE_V1,
        "per-pixel mean of context-kitti-draws (two context blends) and blend-kitti without its mirrored pass, "
        "trained one after the other on the same frames, candidate features shared at prediction; the shipped "
        "kitti-ensemble-v1 (the default)",
    ),
    # kitti-context-v3: two context blends, each on its own samples.
    "context-kitti-draws": (
        ContextBlendInpainter, _CONTEXT_DRAWS,
        "context-kitti-ensemble's two networks, each trained on its own draw of occlusions, thinning and pixels "
        "(member_samples='own'); the same prediction cost, twice the training samples; the shipped kitti-context-v3",
    ),
    # kitti-context-v2: two context blends averaged, on one draw of samples.
    "context-kitti-ensemble": (
        ContextBlendInpainter, _CONTEXT_V2,
        "context-kitti's recipe trained twice from different seeds, the two networks averaged, no mirrored "
        "second pass (same prediction cost); the shipped kitti-context-v2",
    ),
    # kitti-context-v1: the blend plus a scene-context U-Net.
    "context-kitti": (
        ContextBlendInpainter, _CONTEXT_V1,
        "learned blend of five classical fills with scene context from a small U-Net over the whole frame at 1/8 "
        "scale (ContextBlendInpainter), drives weighted equally, thinned copies (keep 1, 0.6), rect-v1; the "
        "shipped kitti-context-v1",
    ),
    # kitti-rect-v4, the default learned release: minutes on 2 CPU cores.
    "blend-kitti": (
        BlendInpainter, _BLEND_V4,
        "per-pixel learned blend of five classical fills (BlendInpainter), features computed once per frame and "
        "occlusion, thinned-input copies (keep 1, 0.65, 0.4), rect-v1; the shipped kitti-rect-v4",
    ),
    # kitti-rect-v3: kitti-rect-v2's recipe with the scale-free blend (relative=True), 1500 steps.
    "cpu-1h": (
        PriorUNetInpainter, {**_BLEND_V2, "relative": True, "max_steps": 1500},
        "scale-free per-pixel learned blend of six classical fills (PixelBlendNet, relative=True), whole frames, "
        "rect-v1, 1500 steps; 55 min on one core of a busy 2-core machine (the shipped kitti-rect-v3)",
    ),
    # kitti-mixed-v1: the scale-free blend trained on the mixture of the four protocols.
    "cpu-1h-mixed": (
        PriorUNetInpainter, {**_BLEND_V2, "relative": True, "protocol": "mixed-v1"},
        "scale-free blend trained on mixed-v1 (each frame's hole from one of the four protocols), 900 steps; "
        "32 min on one core (the shipped kitti-mixed-v1)",
    ),
    # The recipe of kitti-rect-v2: six candidates, fixed depth scale, 900 steps.
    "cpu-1h-v2": (
        PriorUNetInpainter, _BLEND_V2,
        "kitti-rect-v2's recipe: six classical fills, fixed depth scale, 900 steps, 1 thread",
    ),
    # The recipe of the first shipped model, kitti-rect-v1 (four candidates, 300 steps).
    "cpu-1h-v1": (
        PriorUNetInpainter,
        dict(arch="pixel", width=128, levels=3, pixel_batches=8, batch_size=4, lr=2e-3, max_steps=300, epochs=10_000,
             flip=True, tta=True, num_threads=2, random_state=0),
        "kitti-rect-v1's recipe: four classical fills, 300 steps, 2 threads",
    ),
    # The study's variants at a CPU budget (crops, 16-channel 4-level U-Net); the study
    # trained full frames on a GPU. Use --max-steps to set the budget.
    "study-unet-tv": (
        UNetInpainter, {**_STUDY_CPU, "tv_weight": 0.01},
        "the study's U-Net + TV (depth-only input, L1 + 2·L1 hole + 0.01·TV) on 176×416 crops",
    ),
    "study-unet": (
        UNetInpainter, {**_STUDY_CPU, "tv_weight": 0.0},
        "the study's U-Net without TV on 176×416 crops",
    ),
    "study-autoencoder": (
        AutoencoderInpainter, {**_STUDY_CPU, "tv_weight": 0.01},
        "the study's autoencoder ablation (no skips) on 176×416 crops",
    ),
    "unet-mask": (
        UNetInpainter, {**_STUDY_CPU, "tv_weight": 0.01, "input_mask": True},
        "the study's U-Net with hole and validity mask channels on 176×416 crops",
    ),
    "unet-frame": (
        UNetInpainter, {**_STUDY_CPU, "tv_weight": 0.01, "input_mask": True, "depth_scale": "frame"},
        "U-Net + mask channels, depth scaled by each frame's mean observed depth, 176×416 crops",
    ),
    "smoke": (
        PriorUNetInpainter,
        dict(arch="pixel", width=8, levels=1, batch_size=2, max_steps=2, epochs=10_000, num_threads=1, random_state=0),
        "a seconds-long run that checks the pipeline end to end (not a useful model)",
    ),
}


#: Multi-stage recipes: name -> (stages, description). A stage is (estimator class,
#: constructor keywords, share of the training frames it sees, warm-start from the
#: previous stage's fitted model). The study's recipe: train on a 25 % subset, then
#: fine-tune a U-Net initialised from that model on a 50 % subset at lr 5e-4, keeping
#: the checkpoint with the best validation hole RMSE (validation needs >= 2 drives).
STAGED_PRESETS: dict[str, tuple[list[tuple[type, dict[str, Any], float, bool]], str]] = {
    "study": (
        [
            (AutoencoderInpainter, dict(width=32, depth=4, batch_size=4, lr=1e-3, epochs=20,
                                        validation_fraction=0.1, random_state=0), 0.25, False),
            (UNetInpainter, dict(width=32, depth=4, batch_size=4, lr=5e-4, epochs=20,
                                 validation_fraction=0.1, random_state=0), 0.5, True),
        ],
        "the study's two-stage recipe on full frames (GPU-sized): autoencoder on 25 % of "
        "the frames, then a U-Net warm-started from it on 50 % at lr 5e-4; best "
        "validation hole RMSE",
    ),
    "study-cpu": (
        [
            (AutoencoderInpainter, dict(width=16, depth=4, crop=(176, 416), batch_size=4, lr=1e-3,
                                        max_steps=500, epochs=10_000, random_state=0), 0.25, False),
            (UNetInpainter, dict(width=16, depth=4, crop=(176, 416), batch_size=4, lr=5e-4,
                                 max_steps=500, epochs=10_000, random_state=0), 0.5, True),
        ],
        "the study's two stages at a CPU budget (176×416 crops, 16 channels, 500 steps each, "
        "no validation split)",
    ),
}


def available_presets() -> list[str]:
    """Preset names, in definition order (single-stage first, then staged)."""
    return list(PRESETS) + list(STAGED_PRESETS)


def describe_preset(name: str) -> str:
    """One line: the estimator class(es) and what the recipe does."""
    if name in PRESETS:
        cls, _, desc = PRESETS[name]
        return f"{cls.__name__}: {desc}"
    if name in STAGED_PRESETS:
        stages, desc = STAGED_PRESETS[name]
        return f"{' -> '.join(c.__name__ for c, *_ in stages)}: {desc}"
    raise KeyError(f"unknown preset {name!r}; known presets: {', '.join(available_presets())}")


def preset_runs_joblib(name: str) -> bool:
    """Whether preset ``name`` computes its training features with joblib (its estimator has ``n_jobs``).

    Those presets can spread that work over a Dask cluster (``joblib.parallel_backend("dask")``,
    ``inpaintenv train --scheduler``); the step-based ones train in one process.
    """
    describe_preset(name)  # unknown name: the KeyError listing the presets
    return name in PRESETS and "n_jobs" in inspect.signature(PRESETS[name][0].__init__).parameters


def preset_checkpoints(name: str) -> bool:
    """Whether preset ``name`` writes resumable checkpoints (the step-based ones do; the blend presets,
    one pass of minutes, do not)."""
    describe_preset(name)  # unknown name: the KeyError listing the presets
    classes = [c for c, *_ in STAGED_PRESETS[name][0]] if name in STAGED_PRESETS else [PRESETS[name][0]]
    return all("checkpoint_dir" in inspect.signature(c.__init__).parameters for c in classes)


#: Keywords the training runner passes to every preset; dropped for estimators without them.
_RUNNER_KEYWORDS = ("checkpoint_dir", "verbose")


def make_preset(name: str, **overrides: Any) -> Any:
    """The unfitted estimator of preset ``name`` (keywords in ``overrides`` replace its own).

    A key ``member__param`` sets a parameter of the member ``member`` of an ensemble preset
    (``set_params``, as ``GridSearchCV`` does), e.g. ``context__masks_per_frame=6`` for
    ``ensemble-kitti``.

    Raises
    ------
    KeyError
        Unknown preset (the message lists the known ones).
    ValueError
        An override the preset's estimator does not have (e.g. ``max_steps`` for a
        :class:`~estimators.blend.BlendInpainter`, which trains for ``epochs``), or a
        ``member__param`` that names no member's parameter.
    """
    if name not in PRESETS:
        raise KeyError(f"unknown single-stage preset {name!r}; known: {', '.join(PRESETS)}")
    cls, params, _ = PRESETS[name]
    params = copy.deepcopy(params)  # an ensemble's members are objects: each call gets its own
    accepted = set(inspect.signature(cls.__init__).parameters) - {"self"}
    overrides = {k: v for k, v in overrides.items() if k in accepted or k not in _RUNNER_KEYWORDS}
    # member__param (an ensemble member's parameter) goes through set_params, as in GridSearchCV
    nested = {k: v for k, v in overrides.items() if "__" in k}
    unknown = sorted(set(overrides) - accepted - set(nested))
    if unknown:
        raise ValueError(
            f"preset {name!r} ({cls.__name__}) has no parameter {', '.join(unknown)}; "
            f"its parameters: {', '.join(sorted(accepted))}"
        )
    est = cls(**{**params, **{k: v for k, v in overrides.items() if k not in nested}})
    if nested:
        valid = set(est.get_params(deep=True))
        bad = sorted(set(nested) - valid)
        if bad:
            members = sorted({k for k in valid if "__" in k})
            raise ValueError(
                f"preset {name!r} ({cls.__name__}) has no nested parameter {', '.join(bad)}"
                + (f"; its nested parameters: {', '.join(members)}" if members else " (it has no members)")
            )
        est.set_params(**nested)
    return est


def check_preset(name: str, **overrides: Any) -> None:
    """Check preset ``name`` with ``overrides`` without training or writing anything.

    Builds the unfitted estimator of every stage and runs its parameter checks, so that
    ``inpaintenv train`` refuses e.g. ``--max-steps`` for ``blend-kitti`` (which trains
    for ``epochs``) or ``--seed -1`` before it creates its output folder.

    Raises
    ------
    KeyError
        Unknown preset.
    ValueError, TypeError
        An override the estimator does not have, or a value it refuses.
    """
    if name in STAGED_PRESETS:
        stages, _ = STAGED_PRESETS[name]
        ests = []
        for cls, params, _, _ in stages:
            accepted = set(inspect.signature(cls.__init__).parameters) - {"self"}
            unknown = sorted(set(overrides) - accepted)
            if unknown:
                raise ValueError(f"preset {name!r} ({cls.__name__}) has no parameter {', '.join(unknown)}; "
                                 f"its parameters: {', '.join(sorted(accepted))}")
            ests.append(cls(**{**params, **overrides}))
    else:
        ests = [make_preset(name, **overrides)]
    for est in ests:
        check = getattr(est, "_check_params", None)
        if callable(check):
            check()


def train_preset(
    name: str,
    dataset: Any,
    *,
    checkpoint_dir: str | os.PathLike | None = None,
    verbose: bool = False,
    **overrides: Any,
) -> PriorUNetInpainter:
    """Fit preset ``name`` on ``dataset`` (ground-truth frames) and return the estimator.

    Parameters
    ----------
    name : str
        A key of :data:`PRESETS`, e.g. ``"cpu-1h"``.
    dataset : DepthDataset or array-like
        Training frames (metres, 0 = no measurement), e.g. one KITTI drive.
    checkpoint_dir : str or path, optional
        Checkpoint and resume the run there (an interrupted run continues).
    verbose : bool
        Progress bar.
    **overrides
        Estimator parameters replacing the preset's (e.g. ``max_steps=50``).

    Returns
    -------
    PriorUNetInpainter
        Fitted; ``fit_seconds_`` holds the wall-clock training time.
    """
    if name in STAGED_PRESETS:
        return _train_stages(name, dataset, checkpoint_dir=checkpoint_dir, verbose=verbose, **overrides)
    est = make_preset(name, checkpoint_dir=checkpoint_dir, verbose=verbose, **overrides)
    start = time.perf_counter()
    est.fit(dataset)
    est.fit_seconds_ = time.perf_counter() - start
    return est


def _train_stages(
    name: str, dataset: Any, *, checkpoint_dir: str | os.PathLike | None, verbose: bool, **overrides: Any
) -> Any:
    """Run a staged preset; ``overrides`` apply to every stage. Returns the last model
    with ``stages_`` (per stage: class, frames, seconds) and ``fit_seconds_`` (total)."""
    from inpaintenv.data import as_dataset, subset

    data = as_dataset(dataset)
    stages, _ = STAGED_PRESETS[name]
    previous = None
    record = []
    total = 0.0
    drives: set[str] | None = set()
    for k, (cls, params, fraction, warm) in enumerate(stages):
        frames = subset(data, fraction, seed=k) if fraction < 1.0 else data
        stage_dir = None if checkpoint_dir is None else os.path.join(os.fspath(checkpoint_dir), f"stage{k + 1}")
        kwargs = {**params, **overrides, "checkpoint_dir": stage_dir, "verbose": verbose}
        if warm:
            if previous is None:
                raise ValueError(f"preset {name!r}: stage {k + 1} warm-starts but has no previous stage")
            kwargs["warm_start"] = previous
        est = cls(**kwargs)
        start = time.perf_counter()
        est.fit(frames)
        seconds = time.perf_counter() - start
        total += seconds
        record.append({"stage": k + 1, "class": cls.__name__, "frames": len(frames), "seconds": seconds})
        if drives is not None and est.training_drives_ is not None:
            drives |= set(est.training_drives_)
        else:
            drives = None
        previous = est
    previous.stages_ = record
    # The last model inherits what the earlier stages saw through its warm start.
    previous.training_drives_ = None if drives is None else sorted(drives)
    previous.fit_seconds_ = total
    return previous
