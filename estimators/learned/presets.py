"""Named training recipes of ``inpaintenv train --preset NAME``.

A shipped release is its own recipe: preset ``kitti-ensemble-v1`` is the estimator its
JSON (``estimators/pretrained/kitti-ensemble-v1.json``) records, class and parameters,
unfitted (:func:`release_recipe`), so training it on the drives the JSON names makes the
release again; nothing is written down twice. The study's networks, the recipes the
selection compared and a smoke run are in a small table of their own (:data:`STUDY_PRESETS`).

>>> from estimators.learned.presets import train_preset, PRESETS              # doctest: +SKIP
>>> est = train_preset("kitti-mixed-v1", KittiDepth(root, split="train", drives=[...]))
>>> est.save("my-model")

The CLI's ``inpaintenv train --preset NAME`` calls :func:`train_preset`.
"""

from __future__ import annotations

import copy
import inspect
import os
import time
from typing import Any

from inpaintenv.exceptions import InvalidInputError, UnknownNameError
from inpaintenv.methods.learned import RELEASE_DIR, shipped

from . import _checkpoint as ckpt
from ._load import LOADABLE
from ._blend import BlendInpainter
from ._context_blend import ContextBlendInpainter
from ._neural import AutoencoderInpainter, UNetInpainter
from ._prior import PriorUNetInpainter

__all__ = ["PRESETS", "PRESET_ALIASES", "STAGED_PRESETS", "STUDY_PRESETS", "available_presets", "check_preset",
           "describe_preset", "make_preset", "preset_checkpoints", "preset_runs_joblib", "release_recipe",
           "train_preset"]

#: Parameters a release's JSON records that belong to the run, not the recipe (the runner sets them).
_RUN_PARAMS = ("verbose", "checkpoint_dir")


def _recipe(config: dict[str, Any], where: str) -> tuple[type, dict[str, Any]]:
    """The class and constructor keywords a checkpoint config records (an ensemble's members
    built from their nested configs); JSON lists become the tuples the classes take."""
    klass = ckpt.recorded_class(config, where, LOADABLE)
    params = {k: tuple(v) if isinstance(v, list) else v
              for k, v in ckpt.config_value(config, "params", dict, where).items() if k not in _RUN_PARAMS}
    if "members" in config:
        params["estimators"] = []
        for entry in ckpt.config_value(config, "members", list, where):
            member_cls, member_params = _recipe(entry["config"], f"{where} (member {entry['name']!r})")
            params["estimators"].append((entry["name"], member_cls(**member_params)))
    return klass, params


def release_recipe(name: str) -> tuple[type, dict[str, Any]]:
    """The estimator class and parameters shipped release ``name`` was trained with, from its JSON.

    Raises
    ------
    KeyError
        No release of that name is shipped.
    """
    releases = shipped()
    if name not in releases:
        raise UnknownNameError(f"no shipped release {name!r}; shipped: {sorted(releases)}")
    path = RELEASE_DIR / f"{name}.json"
    return _recipe(ckpt._read_json(path), str(path))


def _member(release: str, member: str, **changes: Any) -> dict[str, Any]:
    """The parameters of ensemble release ``release``'s member ``member``, with ``changes``."""
    _, params = release_recipe(release)
    est = dict(params["estimators"])[member]
    return {**est.get_params(deep=False), **changes}


_ENSEMBLE, _MIXED = release_recipe("kitti-ensemble-v1"), release_recipe("kitti-mixed-v1")
_SCAN, _SPARSE = release_recipe("kitti-scan-v1"), release_recipe("kitti-sparse-v1")
#: The context member of kitti-ensemble-v1 (two context blends, each on its own draw of samples).
_CONTEXT = _member("kitti-ensemble-v1", "context")
#: The per-pixel blend member of kitti-ensemble-v1, trained alone: with its mirrored pass.
_BLEND = _member("kitti-ensemble-v1", "blend", tta=True)

#: The shipped releases' recipes and their members', by release name: name -> (estimator class,
#: constructor keywords, one-line description).
RELEASE_PRESETS: dict[str, tuple[type, dict[str, Any], str]] = {
    "kitti-ensemble-v1": (
        *_ENSEMBLE,
        "the shipped default (its JSON's recipe): per-pixel mean of kitti-ensemble-v1-context and "
        "kitti-ensemble-v1-blend without its mirrored pass, trained one after the other on the same frames",
    ),
    "kitti-ensemble-v1-context": (
        ContextBlendInpainter, _CONTEXT,
        "kitti-ensemble-v1's context member alone: two context blends (ContextBlendInpainter), each trained on "
        "its own draw of occlusions, thinning and pixels",
    ),
    "kitti-ensemble-v1-blend": (
        BlendInpainter, _BLEND,
        "kitti-ensemble-v1's blend member alone, with its mirrored pass: per-pixel learned blend of five "
        "classical fills (BlendInpainter), minutes on 2 CPU cores",
    ),
    "kitti-mixed-v1": (
        *_MIXED,
        "the shipped free-form release (its JSON's recipe): scale-free per-pixel blend of six classical fills "
        "trained on mixed-v1 (each frame's hole from one of the four protocols), 900 steps",
    ),
    "kitti-scan-v1": (
        *_SCAN,
        "the shipped scan release (its JSON's recipe; train with --input scan): a single LiDAR scan filled by the "
        "mean of harmonic and ipbasic-scan within 16 px of a measurement, by a learned blend of five classical "
        "fills beyond (ScanBlendInpainter)",
    ),
    "kitti-sparse-v1": (
        *_SPARSE,
        "the shipped sparse-scan release (its JSON's recipe; train with --input scan): harmonic plus a per-pixel "
        "MLP correction, trained on each scan thinned to 32, 16 and 8 beams (SparseResidualInpainter)",
    ),
}

#: The CPU-budget configuration shared by the study's variants below.
_STUDY_CPU: dict[str, Any] = dict(
    width=16, depth=4, crop=(176, 416), batch_size=4, max_steps=1000, epochs=10_000,
    hole_weight=2.0, random_state=0,
)
#: The study's schedule at batch 4 (Adam 1e-3, weight decay 1e-6, λ = 2, β = 0.01).
_STUDY_BATCH, _STUDY_LR, _STUDY_FINE_TUNE_LR = 4, 1e-3, 5e-4
#: The batch the GPU recipes take: the learning rates scale by sqrt(16 / 4) = 2 (docs/neural.md).
_GPU_BATCH = 16
_GPU_LR_SCALE = (_GPU_BATCH / _STUDY_BATCH) ** 0.5
#: The study's networks scaled to one GPU: full 352×1216 frames, batch 16, bf16 autocast,
#: channels-last, 8 persistent loader workers (pinned memory on CUDA) that only decode, the
#: occlusions and flips made on the GPU (sample_device="auto"), random left-right flips (the
#: many more steps a GPU affords see each frame many times), steps bounded by the clock
#: (4 minutes a stage, so autoencoder + U-Net fit in 10 minutes; max_steps only a ceiling).
#: Width 16, the network of the CPU rows (study-unet-tv): a fold's U-Net is 7.9 MB, so four
#: come back from the device machine (width 32 is 31 MB, over its 16 MiB a file).
_STUDY_GPU: dict[str, Any] = dict(
    width=16, depth=4, crop=(352, 1216), batch_size=_GPU_BATCH, weight_decay=1e-6, hole_weight=2.0,
    tv_weight=0.01, amp=True, channels_last=True, num_workers=8, sample_device="auto", flip=True,
    max_steps=1_000_000, epochs=1_000_000, max_minutes=4.0, random_state=0,
)
#: kitti-mixed-v1's recipe on rect-v1 occlusions: the selection's base (experiments/pretrained_selection.py).
_RECT = {**_MIXED[1], "protocol": "rect-v1"}

#: The study's networks at a CPU budget, the recipes the selection compared, and a smoke run.
STUDY_PRESETS: dict[str, tuple[type, dict[str, Any], str]] = {
    "context-kitti": (
        ContextBlendInpainter,
        {**_CONTEXT, "n_members": 1, "member_samples": "shared", "tta": True},
        "one context blend with its mirrored pass (kitti-ensemble-v1's context member, one network): the "
        "recipe the leave-one-day-out check starts from (experiments/lodo_days.sh)",
    ),
    "cpu-1h": (
        PriorUNetInpainter, {**_RECT, "max_steps": 1500},
        "kitti-mixed-v1's recipe on rect-v1 occlusions, 1500 steps (scale-free blend of six classical fills)",
    ),
    "cpu-1h-v2": (
        PriorUNetInpainter, {**_RECT, "relative": False},
        "kitti-mixed-v1's recipe on rect-v1 occlusions at a fixed depth scale (relative=False), 900 steps",
    ),
    "cpu-1h-v1": (
        PriorUNetInpainter,
        dict(arch="pixel", width=128, levels=3, pixel_batches=8, batch_size=4, lr=2e-3, max_steps=300, epochs=10_000,
             flip=True, tta=True, num_threads=2, random_state=0),
        "the first selection's recipe: four classical fills, 300 steps, 2 threads",
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
    # The study's two networks at GPU scale (docs/neural.md "GPU recipes"); the U-Net is the
    # fine-tuning stage: give it the autoencoder with warm_start (or train preset study-gpu).
    "study-autoencoder-gpu": (
        AutoencoderInpainter, {**_STUDY_GPU, "lr": _STUDY_LR * _GPU_LR_SCALE},
        "the study's autoencoder stage on one GPU: full 352×1216 frames, batch 16 at lr 2e-3 (1e-3 × sqrt(16/4)), "
        "bf16, channels-last, 8 workers, flips, occlusions made on the GPU, 4 minutes (max_minutes)",
    ),
    "study-unet-tv-gpu": (
        UNetInpainter, {**_STUDY_GPU, "lr": _STUDY_FINE_TUNE_LR * _GPU_LR_SCALE},
        "the study's U-Net + TV fine-tuning stage on one GPU: as study-autoencoder-gpu at lr 1e-3 (5e-4 × "
        "sqrt(16/4)); --set warm_start=<saved autoencoder> starts its encoder from that stage",
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

#: Former preset names -> the release-named preset each stands for.
PRESET_ALIASES: dict[str, str] = {
    "ensemble-kitti": "kitti-ensemble-v1",
    "cpu-1h-mixed": "kitti-mixed-v1",
    "context-kitti-draws": "kitti-ensemble-v1-context",
    "blend-kitti": "kitti-ensemble-v1-blend",
}

#: Every single-stage preset: name -> (estimator class, constructor keywords, one-line description).
#: An alias maps to its target's entry, its description saying so.
PRESETS: dict[str, tuple[type, dict[str, Any], str]] = {
    **RELEASE_PRESETS,
    **{alias: (*RELEASE_PRESETS[target][:2], f"former name of {target}: {RELEASE_PRESETS[target][2]}")
       for alias, target in PRESET_ALIASES.items()},
    **STUDY_PRESETS,
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
    "study-gpu": (
        [
            (AutoencoderInpainter, PRESETS["study-autoencoder-gpu"][1], 1.0, False),
            (UNetInpainter, PRESETS["study-unet-tv-gpu"][1], 1.0, True),
        ],
        "the study's two stages on one GPU (study-autoencoder-gpu, then study-unet-tv-gpu warm-started from it), "
        "all the training frames, 4 minutes each",
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
    raise UnknownNameError(f"unknown preset {name!r}; known presets: {', '.join(available_presets())}")


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
        :class:`~estimators.learned.BlendInpainter`, which trains for ``epochs``), or a
        ``member__param`` that names no member's parameter.
    """
    if name not in PRESETS:
        raise UnknownNameError(f"unknown single-stage preset {name!r}; known: {', '.join(PRESETS)}")
    cls, params, _ = PRESETS[name]
    params = copy.deepcopy(params)  # an ensemble's members are objects: each call gets its own
    accepted = set(inspect.signature(cls.__init__).parameters) - {"self"}
    overrides = {k: v for k, v in overrides.items() if k in accepted or k not in _RUNNER_KEYWORDS}
    # member__param (an ensemble member's parameter) goes through set_params, as in GridSearchCV
    nested = {k: v for k, v in overrides.items() if "__" in k}
    unknown = sorted(set(overrides) - accepted - set(nested))
    if unknown:
        raise InvalidInputError(
            f"preset {name!r} ({cls.__name__}) has no parameter {', '.join(unknown)}; "
            f"its parameters: {', '.join(sorted(accepted))}"
        )
    est = cls(**{**params, **{k: v for k, v in overrides.items() if k not in nested}})
    if nested:
        valid = set(est.get_params(deep=True))
        bad = sorted(set(nested) - valid)
        if bad:
            members = sorted({k for k in valid if "__" in k})
            raise InvalidInputError(
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
                raise InvalidInputError(f"preset {name!r} ({cls.__name__}) has no parameter {', '.join(unknown)}; "
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
                raise InvalidInputError(f"preset {name!r}: stage {k + 1} warm-starts but has no previous stage")
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
