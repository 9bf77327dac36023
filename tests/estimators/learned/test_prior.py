"""PriorUNet inpainter: candidate fills, the network, the estimator, presets, shipped weights."""

from __future__ import annotations

import re
import numpy as np
import pytest
import torch

from estimators.classical import ScanlineInpainter
from estimators.learned.nets.pixel_blend import PixelBlendNet
from estimators.learned.nets.prior_unet import PriorUNet
from estimators.learned.presets import available_presets, make_preset, train_preset
from estimators.learned import PriorUNetInpainter
from training_helpers import interrupt_after
from estimators.candidates import (
    AVAILABLE_CANDIDATES,
    CANDIDATES,
    NO_MEASUREMENT_DISTANCE,
    candidate_fills,
    endpoint_values,
    gap_distances,
    prior_features,
    row_band_quantile,
)

TINY = {"width": 4, "levels": 1, "factor": 2, "batch_size": 2, "max_steps": 2, "random_state": 0, "num_threads": 1}
ARCH_IDS = ["pixel", "unet"]


def _corrupt(frames: np.ndarray) -> np.ndarray:
    x = frames.copy()
    x[:, 8:20, 10:30] = np.nan
    return x


# -- priors ----------------------------------------------------------------------------
def test_candidates_keep_measured_pixels_and_fill_holes(small_gt):
    x = _corrupt(small_gt)[0]
    fills = candidate_fills(x)
    assert fills.shape == (len(CANDIDATES), *x.shape) and fills.dtype == np.float32
    measured = x > 0
    assert np.allclose(fills[:, measured], x[measured])
    assert np.isfinite(fills).all() and (fills[:, np.isnan(x)] > 0).all()


def test_scanline_candidate_is_the_scanline_estimator(small_gt):
    x = _corrupt(small_gt)[:1]
    expected = ScanlineInpainter(keep_observed=False).predict(x)[0]
    np.testing.assert_allclose(candidate_fills(x[0], ["scanline"])[0], expected, rtol=1e-6)


def test_prior_features_channels(small_gt):
    x = _corrupt(small_gt)[0]
    f = prior_features(x, ["harmonic"])
    assert f.shape == (4, *x.shape)
    np.testing.assert_array_equal(f[1] == 1, np.isnan(x))
    np.testing.assert_array_equal(f[2] == 1, x > 0)
    assert (f[0][~(x > 0)] == 0).all()


@pytest.mark.parametrize("names", [[], ["sobel"], "scanline"])
def test_unknown_candidates_raise(small_gt, names):
    with pytest.raises(ValueError, match="candidates"):
        candidate_fills(_corrupt(small_gt)[0], names)


def test_gap_distances():
    known = np.zeros((3, 6), bool)
    known[1, 1] = known[1, 4] = True
    d = gap_distances(known)
    assert d.shape == (4, 3, 6)
    np.testing.assert_array_equal(d[:, 1, 2], [1, 2, NO_MEASUREMENT_DISTANCE, NO_MEASUREMENT_DISTANCE])
    np.testing.assert_array_equal(d[:, 0, 1], [NO_MEASUREMENT_DISTANCE, NO_MEASUREMENT_DISTANCE, NO_MEASUREMENT_DISTANCE, 1])
    assert (d[:, known] == 0).all()
    with pytest.raises(ValueError, match="bool"):
        gap_distances(known.astype(int))


def test_prior_features_with_gaps(small_gt):
    x = _corrupt(small_gt)[0]
    f = prior_features(x, gaps=True)
    assert f.shape == (3 + len(CANDIDATES) + 4, *x.shape)
    np.testing.assert_array_equal(f[-4:], gap_distances(x > 0))


def test_endpoint_values():
    values = np.array([[1, 0, 0, 4], [0, 2, 0, 0]], np.float32)
    e = endpoint_values(values, values > 0)
    np.testing.assert_array_equal(e[0], [[1, 1, 1, 4], [0, 2, 2, 2]])  # left
    np.testing.assert_array_equal(e[1], [[1, 4, 4, 4], [2, 2, 0, 0]])  # right
    np.testing.assert_array_equal(e[2], [[1, 0, 0, 4], [1, 2, 0, 4]])  # up
    np.testing.assert_array_equal(e[3], [[1, 2, 0, 4], [0, 2, 0, 0]])  # down
    with pytest.raises(ValueError, match="one shape"):
        endpoint_values(values, (values > 0)[:1])


def test_prior_features_with_endpoints(small_gt):
    x = _corrupt(small_gt)[0]
    f = prior_features(x, gaps=True, endpoints=True)
    assert f.shape == (3 + len(CANDIDATES) + 8, *x.shape)
    np.testing.assert_array_equal(f[-4:], endpoint_values(np.where(x > 0, x, 0), x > 0))


def test_every_available_candidate_keeps_measured_pixels(small_gt):
    x = _corrupt(small_gt)[0]
    fills = candidate_fills(x, AVAILABLE_CANDIDATES)
    assert np.isfinite(fills).all() and (fills[:, np.isnan(x)] > 0).all()
    np.testing.assert_array_equal(fills[:, x > 0], np.broadcast_to(x[x > 0], (len(AVAILABLE_CANDIDATES), (x > 0).sum())))


def _row_band_quantile_reference(values, known, q, band):
    """Row by row with NumPy's nanquantile; rows with no data in their band stay NaN."""
    v = np.where(known, values, np.nan)
    out = np.full(len(v), np.nan)
    for r in range(len(v)):
        block = v[max(0, r - band): r + band + 1]
        if np.isfinite(block).any():
            out[r] = np.nanquantile(block, q)
    return out


@pytest.mark.parametrize("q", [0.0, 0.5, 0.9, 1.0])
def test_row_band_quantile_matches_nanquantile(q):
    rng = np.random.default_rng(1)
    values = rng.uniform(2, 80, (30, 17)).astype(np.float32)
    known = rng.random(values.shape) < 0.3
    known[:8] = False  # rows far from any measurement take the nearest covered row's value
    out = row_band_quantile(values, known, q, band=2)
    ref = _row_band_quantile_reference(values, known, q, band=2)
    covered = np.isfinite(ref)
    for r in np.nonzero(covered)[0]:
        np.testing.assert_allclose(out[r][~known[r]], ref[r], rtol=1e-5)
    np.testing.assert_array_equal(out[known], values[known])
    first = np.argmax(covered)
    np.testing.assert_allclose(out[:first], ref[first], rtol=1e-5)


def test_row_band_quantile_edge_cases():
    values = np.full((4, 5), 7.0, np.float32)
    assert not row_band_quantile(values, np.zeros((4, 5), bool), 0.5).any()  # nothing measured: zeros
    with pytest.raises(ValueError, match="q must be in"):
        row_band_quantile(values, values > 0, 1.5)
    with pytest.raises(ValueError, match="band must be"):
        row_band_quantile(values, values > 0, 0.5, band=-1)
    with pytest.raises(ValueError, match="one shape"):
        row_band_quantile(values, np.ones((4, 4), bool), 0.5)


def test_priors_reject_batches():
    with pytest.raises(ValueError, match="2-D"):
        prior_features(np.ones((2, 4, 4), dtype=np.float32))


# -- network ---------------------------------------------------------------------------
def test_untrained_net_is_mean_of_candidates_any_size():
    net = PriorUNet(n_candidates=2, width=4, levels=1, factor=2)
    x = torch.rand(2, 5, 13, 22) * 30
    out = net(x)
    assert out.shape == (2, 13, 22)
    torch.testing.assert_close(out, x[:, 3:].mean(1))


def test_untrained_pixel_net_is_mean_of_candidates_and_keeps_measured():
    net = PixelBlendNet(n_candidates=2, n_gaps=4, width=8, layers=2)
    x = torch.rand(2, 9, 5, 7) * 30
    x[:, 2] = (torch.rand(2, 5, 7) > 0.5).float()
    out = net(x)
    unknown = x[:, 2] < 0.5
    torch.testing.assert_close(out[unknown], x[:, 3:5].mean(1)[unknown])
    torch.testing.assert_close(out[~unknown], x[:, 0][~unknown])
    torch.testing.assert_close(net(x, where=unknown), out[unknown])


@pytest.mark.parametrize("n_endpoints", [0, 4])
def test_relative_pixel_net_scales_with_depth(n_endpoints):
    torch.manual_seed(0)
    net = PixelBlendNet(n_candidates=3, n_gaps=4, width=8, layers=2, n_endpoints=n_endpoints, relative=True)
    torch.nn.init.normal_(net.head.weight)  # a trained-looking head, not the zero start
    torch.nn.init.normal_(net.head.bias)
    pixels = torch.rand(50, 3 + 4 + n_endpoints, dtype=torch.float64) * 40 + 1
    net = net.double()
    scaled = pixels.clone()
    scaled[:, :3] *= 7.5  # candidates
    scaled[:, 7:] *= 7.5  # endpoint depths; the gap lengths (pixels) do not scale
    torch.testing.assert_close(net.blend(scaled), 7.5 * net.blend(pixels))
    if n_endpoints:  # a missing endpoint (0 m) stays finite and scale-free
        pixels[:5, 7], scaled[:5, 7] = 0.0, 0.0
        torch.testing.assert_close(net.blend(scaled), 7.5 * net.blend(pixels))
    # The fixed-scale net does not have this property.
    fixed = PixelBlendNet(n_candidates=3, n_gaps=4, width=8, layers=2, n_endpoints=n_endpoints).double()
    fixed.load_state_dict(net.state_dict())
    assert not torch.allclose(fixed.blend(scaled), 7.5 * fixed.blend(pixels))


def test_net_rejects_wrong_channels():
    with pytest.raises(ValueError, match="expected input"):
        PriorUNet(n_candidates=2, width=4, levels=1, factor=2)(torch.zeros(1, 4, 8, 8))
    with pytest.raises(ValueError, match="expected input"):
        PixelBlendNet(n_candidates=2, n_gaps=4, width=4, layers=1)(torch.zeros(1, 5, 8, 8))



# -- estimator -------------------------------------------------------------------------
@pytest.mark.parametrize("arch", ARCH_IDS)
def test_fit_predict_keeps_observed(small_gt, arch):
    est = PriorUNetInpainter(**TINY, arch=arch).fit(small_gt)
    assert est.n_steps_ == 2 and np.isfinite(est.history_["step_loss"]).all()
    x = _corrupt(small_gt)
    pred = est.predict(x)
    assert pred.shape == x.shape and np.isfinite(pred).all() and (pred >= 0).all()
    np.testing.assert_array_equal(pred[x > 0], x[x > 0])


def test_flip_swaps_left_and_right_gaps(small_gt):
    est = PriorUNetInpainter(**TINY)
    x = est._features(_corrupt(small_gt))
    flipped = est._flip(x)
    k = 3 + len(CANDIDATES)
    torch.testing.assert_close(flipped[:, k], x[:, k + 1].flip(-1))
    torch.testing.assert_close(flipped[:, :k], x[:, :k].flip(-1))
    # Features of the mirrored frame are the mirrored features (up to float round-off).
    np.testing.assert_allclose(
        est._features(_corrupt(small_gt)[:, :, ::-1].copy()).numpy(), flipped.numpy(), rtol=1e-5
    )


def test_flip_with_endpoints_matches_features_of_the_mirrored_frame(small_gt):
    est = PriorUNetInpainter(**TINY, endpoints=True)
    x = est._features(_corrupt(small_gt))
    assert x.shape[1] == est.in_channels == 3 + len(CANDIDATES) + 8
    np.testing.assert_allclose(
        est._features(_corrupt(small_gt)[:, :, ::-1].copy()).numpy(), est._flip(x).numpy(), rtol=1e-5
    )
    pred = est.fit(small_gt).predict(_corrupt(small_gt))
    assert np.isfinite(pred).all()


def test_relative_estimator_prediction_scales_with_input(small_gt):
    est = PriorUNetInpainter(**TINY, relative=True).fit(small_gt)
    x = _corrupt(small_gt)
    # Every candidate fill, the floor and the blend scale with depth; gap lengths do not change.
    np.testing.assert_allclose(est.predict(3.0 * x), 3.0 * est.predict(x), rtol=2e-5)


def test_relative_is_saved_and_loaded(small_gt, tmp_path):
    est = PriorUNetInpainter(**TINY, relative=True).fit(small_gt)
    loaded = PriorUNetInpainter.load(est.save(tmp_path / "m"))
    assert loaded.relative is True and loaded.model_.relative
    np.testing.assert_allclose(loaded.predict(_corrupt(small_gt)), est.predict(_corrupt(small_gt)))


def test_pixel_batches_give_more_updates_per_step(small_gt):
    one = PriorUNetInpainter(**{**TINY, "pixel_batches": 1}).fit(small_gt)
    three = PriorUNetInpainter(**{**TINY, "pixel_batches": 3}).fit(small_gt)
    assert one.n_steps_ == three.n_steps_ == 2
    # Same first batch of frames; three updates move the weights further than one.
    w0 = PriorUNetInpainter(**TINY)._build_model(0).head.weight
    assert (three.model_.head.weight - w0).abs().sum() > (one.model_.head.weight - w0).abs().sum()


def test_training_is_reproducible(small_gt):
    a = PriorUNetInpainter(**TINY).fit(small_gt)
    b = PriorUNetInpainter(**TINY).fit(small_gt)
    assert a.history_["step_loss"] == b.history_["step_loss"]


def _interrupt_after(monkeypatch, n_steps: int) -> None:
    interrupt_after(monkeypatch, PriorUNetInpainter, n_steps)


@pytest.mark.parametrize("arch", ARCH_IDS)
def test_resume_equals_uninterrupted_run_bit_for_bit(small_gt, tmp_path, monkeypatch, arch):
    # Flips (p = 0.5) and the per-pixel shuffles draw from one stream that advances every
    # step: a resumed run must continue it from the checkpoint, not restart it.
    kw = {**TINY, "arch": arch, "batch_size": 1, "max_steps": 6, "epochs": 3, "checkpoint_every": 1}
    full = PriorUNetInpainter(**kw, checkpoint_dir=tmp_path / "a").fit(small_gt)
    with monkeypatch.context() as m:
        _interrupt_after(m, 4)  # mid-epoch 2 (3 frames, batch 1 -> 3 steps per epoch)
        with pytest.raises(KeyboardInterrupt):
            PriorUNetInpainter(**kw, checkpoint_dir=tmp_path / "b").fit(small_gt)
    resumed = PriorUNetInpainter(**kw, checkpoint_dir=tmp_path / "b").fit(small_gt)
    assert resumed.n_steps_ == full.n_steps_ == 6
    assert resumed.history_ == full.history_
    for key, value in full.model_.state_dict().items():
        assert torch.equal(resumed.model_.state_dict()[key], value), key
    x = _corrupt(small_gt)
    np.testing.assert_array_equal(resumed.predict(x), full.predict(x))


@pytest.mark.parametrize("arch", ARCH_IDS)
def test_save_load_roundtrip(small_gt, tmp_path, arch):
    est = PriorUNetInpainter(**TINY, arch=arch, candidates=("scanline", "vertical")).fit(small_gt)
    loaded = PriorUNetInpainter.load(est.save(tmp_path / "m"))
    assert loaded.candidates == ("scanline", "vertical") and loaded.arch == arch
    x = _corrupt(small_gt)
    np.testing.assert_allclose(loaded.predict(x), est.predict(x))


@pytest.mark.parametrize(
    ("param", "value", "error"),
    [("factor", 0, ValueError), ("arch", "transformer", ValueError), ("pixel_batches", 0, ValueError), ("candidates", ("nope",), ValueError), ("tta", "yes", TypeError), ("endpoints", 1, TypeError), ("relative", "no", TypeError),
     ("levels", 0, ValueError)],
)
def test_bad_params_raise_clear_errors(small_gt, param, value, error):
    with pytest.raises(error, match=rf"^{param} must be .*, got {re.escape(repr(value))}$"):
        PriorUNetInpainter(**{**TINY, param: value}).fit(small_gt)


def test_unet_arch_needs_frames_of_its_downsampling(small_gt):
    with pytest.raises(ValueError, match=r"factor=8, levels=3 \(factor \* 2\*\*levels = 64 px\) needs training frames"):
        PriorUNetInpainter(**{**TINY, "arch": "unet", "factor": 8, "levels": 3}).fit(small_gt)
    with pytest.raises(ValueError, match=r"width=512, levels=3 gives 4096 channels at the deepest level \(width \* 2\*\*levels\)"):
        PriorUNetInpainter(**{**TINY, "arch": "unet", "width": 512, "levels": 3}).fit(small_gt)
    # The pixel MLP neither downsamples nor doubles its width per layer.
    PriorUNetInpainter(**{**TINY, "levels": 3, "width": 8}).fit(small_gt)


# -- presets -----------------------------------------------------------------------------
def test_presets_listed_and_unknown_raises():
    assert "cpu-1h" in available_presets()
    assert make_preset("cpu-1h").max_steps >= 1
    with pytest.raises(KeyError, match="cpu-1h"):
        make_preset("gpu-1w")


def test_train_preset_smoke(small_gt):
    est = train_preset("smoke", small_gt)
    assert est.n_steps_ == 2 and est.fit_seconds_ > 0


@pytest.mark.parametrize("arch", ARCH_IDS)
def test_model_params_changed_after_fit_raise(small_gt, arch):
    est = PriorUNetInpainter(**TINY, arch=arch).fit(small_gt)
    x = _corrupt(small_gt)
    params = est.get_params()
    change = {"relative": True} if arch == "pixel" else {"factor": 4}
    with pytest.raises(ValueError, match=f"^{next(iter(change))}=.* differs from the .* this model was trained with"):
        est.set_params(**change).predict(x)
    with pytest.raises(ValueError, match=r"^candidates=\('scanline',\) differs"):
        est.set_params(**{**params, "candidates": ["scanline"]}).predict(x)
    # A list equal to the fitted tuple is the same setting; tta is prediction-time.
    est.set_params(**{**params, "candidates": list(CANDIDATES), "tta": False})
    assert est.predict(x).shape == x.shape
