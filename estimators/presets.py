"""Named training recipes, e.g. ``cpu-1h``: the shipped model's recipe, reproducible on a laptop.

>>> from estimators.presets import train_preset, PRESETS              # doctest: +SKIP
>>> est = train_preset("cpu-1h", KittiDepth(root, split="train", drives=[...]))
>>> est.save("my-model")

The CLI's ``inpaintenv train --preset NAME`` calls :func:`train_preset`.
"""

from __future__ import annotations

import os
import time
from typing import Any

from .neural import AutoencoderInpainter, UNetInpainter
from .prior import PriorUNetInpainter

__all__ = ["PRESETS", "available_presets", "make_preset", "train_preset"]

#: name -> (estimator class, constructor keywords, one-line description).
PRESETS: dict[str, tuple[type, dict[str, Any], str]] = {
    "cpu-1h": (
        PriorUNetInpainter,
        dict(arch="pixel", width=128, levels=3, pixel_batches=8, batch_size=4, lr=2e-3, max_steps=300, epochs=10_000,
             flip=True, tta=True, num_threads=2, random_state=0),
        "per-pixel learned blend of classical fills (PixelBlendNet), whole frames, rect-v1; "
        "< 1 h on 2 CPU cores",
    ),
    # The study's variants at a CPU budget (crops, 16-channel 4-level U-Net); the study
    # trained full frames on a GPU. Use --max-steps to set the budget.
    "study-unet-tv": (
        UNetInpainter,
        dict(width=16, depth=4, crop=(176, 416), batch_size=4, max_steps=1000, epochs=10_000,
             hole_weight=2.0, tv_weight=0.01, random_state=0),
        "the study's U-Net + TV (depth-only input, L1 + 2·L1 hole + 0.01·TV) on 176×416 crops",
    ),
    "study-unet": (
        UNetInpainter,
        dict(width=16, depth=4, crop=(176, 416), batch_size=4, max_steps=1000, epochs=10_000,
             hole_weight=2.0, tv_weight=0.0, random_state=0),
        "the study's U-Net without TV on 176×416 crops",
    ),
    "study-autoencoder": (
        AutoencoderInpainter,
        dict(width=16, depth=4, crop=(176, 416), batch_size=4, max_steps=1000, epochs=10_000,
             hole_weight=2.0, tv_weight=0.01, random_state=0),
        "the study's autoencoder ablation (no skips) on 176×416 crops",
    ),
    "unet-mask": (
        UNetInpainter,
        dict(width=16, depth=4, crop=(176, 416), batch_size=4, max_steps=1000, epochs=10_000,
             hole_weight=2.0, tv_weight=0.01, input_mask=True, random_state=0),
        "the study's U-Net with hole and validity mask channels on 176×416 crops",
    ),
    "smoke": (
        PriorUNetInpainter,
        dict(arch="pixel", width=8, levels=1, batch_size=2, max_steps=2, epochs=10_000, num_threads=1, random_state=0),
        "a seconds-long run that checks the pipeline end to end (not a useful model)",
    ),
}


def available_presets() -> list[str]:
    """Preset names, in definition order."""
    return list(PRESETS)


def make_preset(name: str, **overrides: Any) -> PriorUNetInpainter:
    """The unfitted estimator of preset ``name`` (keywords in ``overrides`` replace its own).

    Raises
    ------
    KeyError
        Unknown preset (the message lists the known ones).
    """
    if name not in PRESETS:
        raise KeyError(f"unknown preset {name!r}; known presets: {', '.join(PRESETS)}")
    cls, params, _ = PRESETS[name]
    return cls(**{**params, **overrides})


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
    est = make_preset(name, checkpoint_dir=checkpoint_dir, verbose=verbose, **overrides)
    start = time.perf_counter()
    est.fit(dataset)
    est.fit_seconds_ = time.perf_counter() - start
    return est
