"""The study's GPU recipes (study-autoencoder-gpu, study-unet-tv-gpu, study-gpu): built, checked, smoke-fitted on CPU."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from estimators.learned import AutoencoderInpainter, UNetInpainter
from estimators.learned.presets import PRESETS, STAGED_PRESETS, check_preset, make_preset, train_preset
from inpaintenv.data import ArrayDataset

GPU = ("study-autoencoder-gpu", "study-unet-tv-gpu")
#: Tiny frames and steps for a CPU smoke run of a GPU recipe.
TINY = dict(crop=(32, 64), width=4, depth=2, batch_size=2, max_steps=2, num_workers=0, device="cpu", num_threads=1)


def _frames(n: int = 4) -> np.ndarray:
    rng = np.random.default_rng(0)
    rows = np.linspace(5.0, 40.0, 32, dtype=np.float32)[:, None]
    frames = np.stack([rows + np.linspace(0.0, 3.0, 64, dtype=np.float32)[None, :] + k for k in range(n)])
    frames[rng.random(frames.shape) < 0.3] = 0.0
    return frames.astype(np.float32)


@pytest.mark.parametrize("name", GPU)
def test_gpu_recipe_is_the_study_schedule_scaled_to_a_gpu(name):
    check_preset(name)  # the constraints table accepts it
    est = make_preset(name)
    p = est.get_params()
    assert (p["hole_weight"], p["tv_weight"], p["weight_decay"]) == (2.0, 0.01, 1e-6)
    assert p["crop"] == (352, 1216) and p["batch_size"] == 16 and p["width"] == 16
    assert p["amp"] is True and p["channels_last"] is True and p["num_workers"] == 8
    # Flips on (many more steps see each frame many times); occlusions made on the GPU when there is one.
    assert p["flip"] is True and p["depth_jitter"] is None and p["sample_device"] == "auto"
    assert p["max_minutes"] == 4.0
    study_lr = 1e-3 if name == "study-autoencoder-gpu" else 5e-4  # the study's stage lr at batch 4
    assert p["lr"] == pytest.approx(study_lr * math.sqrt(16 / 4))


def test_staged_gpu_recipe_warm_starts_the_unet_from_the_autoencoder_within_ten_minutes():
    stages, _ = STAGED_PRESETS["study-gpu"]
    (ae_cls, ae, _, ae_warm), (unet_cls, unet, _, unet_warm) = stages
    assert (ae_cls, unet_cls) == (AutoencoderInpainter, UNetInpainter)
    assert (ae_warm, unet_warm) == (False, True)
    assert ae == PRESETS["study-autoencoder-gpu"][1] and unet == PRESETS["study-unet-tv-gpu"][1]
    assert ae["max_minutes"] + unet["max_minutes"] <= 10  # the budget for both stages


@pytest.mark.parametrize("name", GPU)
def test_gpu_recipe_smoke_fits_on_cpu(name):
    est = make_preset(name).set_params(**TINY)
    est.fit(_frames())
    assert est.n_steps_ == 2 and "budget_stop" not in est.history_
    assert est.predict(np.where(_frames(1) > 30, np.nan, _frames(1))).shape == (1, 32, 64)


def test_unet_gpu_recipe_starts_its_encoder_from_the_autoencoder():
    ae = make_preset("study-autoencoder-gpu").set_params(**TINY).fit(_frames())
    unet = make_preset("study-unet-tv-gpu").set_params(**{**TINY, "max_steps": 1}, warm_start=ae)
    seen = {}
    real = UNetInpainter._train_step

    def first_step(self, model, *args):  # the encoder before any step of the fine-tuning
        seen.setdefault("encoder", {k: v.clone() for k, v in model.encoder.state_dict().items()})
        return real(self, model, *args)

    with pytest.MonkeyPatch.context() as m:
        m.setattr(UNetInpainter, "_train_step", first_step)
        unet.fit(_frames())
    for key, value in ae.model_.encoder.state_dict().items():
        assert torch.equal(seen["encoder"][key], value), key


def test_staged_gpu_preset_trains_both_stages_on_cpu():
    est = train_preset("study-gpu", ArrayDataset(_frames()), **TINY)
    assert [s["class"] for s in est.stages_] == ["AutoencoderInpainter", "UNetInpainter"]
    assert est.n_steps_ == 2
