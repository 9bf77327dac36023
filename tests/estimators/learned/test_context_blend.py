"""ContextBlendInpainter: training samples, context grid, prediction, persistence, errors."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from streets import streets as _streets

from estimators.learned import ContextBlendInpainter
from estimators.learned.nets.context_blend import (
    CELL,
    ContextBlendNet,
    context_grid,
    frame_reference,
)
from estimators.learned.nets.pixel_blend import PixelBlendNet
from estimators.candidates import candidate_fills
from inpaintenv.data import ArrayDataset

TINY = dict(n_context=3, context_widths=(4, 8), width=8, layers=1, epochs=2, masks_per_frame=2, keep=(1.0, 0.6),
            pixels_per_frame=200, batch_frames=3, batch_pixels=64, num_threads=1)


@pytest.fixture(scope="module")
def fitted() -> ContextBlendInpainter:
    return ContextBlendInpainter(**TINY).fit(ArrayDataset(_streets(), groups=list("aaaabc")))


def _corrupt(gt: np.ndarray) -> np.ndarray:
    x = gt.copy()
    x[10:25, 30:70] = np.nan
    return x


def test_context_grid_is_scale_free_and_sized_by_cells():
    gt = _streets(1, 37, 53)[0]
    x = _corrupt(gt)
    cands = candidate_fills(x, ("scanline", "harmonic-inverse"))
    grid = context_grid(x, cands)
    assert grid.shape == (5, 5, 7)  # ceil(ceil(37 / 4) / 2), ceil(ceil(53 / 4) / 2)
    twice = context_grid(2 * x, 2 * cands)
    np.testing.assert_allclose(twice, grid, atol=1e-5)  # log-depths relative to the frame's median
    assert frame_reference(2 * x) == pytest.approx(frame_reference(x) + np.log(2.0))
    assert 0.0 <= grid[1].min() and grid[1].max() <= 1.0 and 0.0 <= grid[2].min() and grid[2].max() <= 1.0


def test_fit_predicts_every_pixel_and_keeps_measurements(fitted):
    gt = _streets(1, seed=5)[0]
    x = _corrupt(gt)
    pred = fitted.predict(x)
    assert pred.shape == x.shape and pred.dtype == np.float32 and np.isfinite(pred).all()
    measured = x > 0
    np.testing.assert_array_equal(pred[measured], x[measured])
    assert (pred > 0).all()
    assert len(fitted.history_["epoch_loss"]) == TINY["epochs"]
    assert fitted.n_samples_ <= 6 * TINY["masks_per_frame"] * len(TINY["keep"]) and fitted.training_frames_ == 6


def test_any_frame_size(fitted):
    for h, w in [(23, 41), (64, 200), (9, 17)]:
        gt = _streets(1, h, w)[0]
        x = gt.copy()
        x[h // 4: h // 2, w // 4: w // 2] = np.nan
        pred = fitted.predict(x)
        assert pred.shape == (h, w) and np.isfinite(pred).all()


def test_scale_equivariant(fitted):
    x = _corrupt(_streets(1, seed=3)[0])
    np.testing.assert_allclose(fitted.predict(2.0 * x), 2.0 * fitted.predict(x), rtol=2e-4)


def test_same_seed_same_weights_and_save_load_round_trip(fitted, tmp_path):
    again = ContextBlendInpainter(**TINY).fit(ArrayDataset(_streets(), groups=list("aaaabc")))
    for a, b in zip(fitted.model_.state_dict().values(), again.model_.state_dict().values()):
        assert torch.equal(a, b)
    folder = fitted.save(tmp_path / "model")
    loaded = ContextBlendInpainter.load(folder)
    x = _corrupt(_streets(1, seed=4)[0])
    np.testing.assert_array_equal(loaded.predict(x), fitted.predict(x))
    assert loaded.context_widths == TINY["context_widths"] and loaded.training_drives_ == ["a", "b", "c"]


def test_an_ensemble_averages_members_trained_from_other_seeds(fitted, tmp_path):
    import copy

    data = ArrayDataset(_streets(), groups=list("aaaabc"))
    pair = ContextBlendInpainter(**TINY, n_members=2).fit(data)
    first, second = pair._networks()
    # member 0 is the network one member trains; member 1 starts from another seed
    for a, b in zip(first.state_dict().values(), fitted.model_.state_dict().values()):
        assert torch.equal(a, b)
    assert any(not torch.equal(a, b) for a, b in zip(second.state_dict().values(), first.state_dict().values()))
    assert len(pair.history_["member_epoch_loss"]) == 2
    x = _corrupt(_streets(1, seed=6)[0])
    alone = []
    for net in (first, second):
        one = copy.copy(fitted)
        one.model_ = net
        alone.append(one.predict(x))
    hole = np.isnan(x)
    np.testing.assert_allclose(pair.predict(x)[hole], ((alone[0] + alone[1]) / 2)[hole], rtol=1e-5)
    loaded = ContextBlendInpainter.load(pair.save(tmp_path / "pair"))
    assert loaded.n_members == 2 and loaded.model_params_["n_members"] == 2
    np.testing.assert_array_equal(loaded.predict(x), pair.predict(x))
    # one network records no n_members: releases made before ensembles load unchanged
    assert "n_members" not in fitted.model_params_


def test_members_with_their_own_samples_train_on_other_draws(fitted, tmp_path):
    data = ArrayDataset(_streets(), groups=list("aaaabc"))
    own = ContextBlendInpainter(**TINY, n_members=2, member_samples="own").fit(data)
    shared = ContextBlendInpainter(**TINY, n_members=2).fit(data)
    # member 0 is still the one-network model: its draw and its initialisation
    for a, b in zip(own._networks()[0].state_dict().values(), fitted.model_.state_dict().values()):
        assert torch.equal(a, b)
    # member 1 starts from the same seed in both modes, so only its samples differ
    own_1, shared_1 = own._networks()[1].state_dict(), shared._networks()[1].state_dict()
    assert any(not torch.equal(own_1[k], shared_1[k]) for k in own_1)
    seed_1 = int(np.random.SeedSequence([0, 0xE75]).generate_state(1)[0])
    drawn = [len(s) for s in (own.training_samples(data, seed=0)[0], own.training_samples(data, seed=seed_1)[0])]
    assert own.n_samples_ == sum(drawn) and shared.n_samples_ == fitted.n_samples_ == drawn[0]
    assert own.training_frames_ == fitted.training_frames_
    loaded = ContextBlendInpainter.load(own.save(tmp_path / "own"))
    assert loaded.member_samples == "own"
    x = _corrupt(_streets(1, seed=6)[0])
    np.testing.assert_array_equal(loaded.predict(x), own.predict(x))


def test_balance_gives_drives_equal_shares():
    est = ContextBlendInpainter(**{**TINY, "balance": 1.0})
    samples, groups = est.training_samples(ArrayDataset(_streets(), groups=list("aaaabc")), seed=0)
    assert len(samples) == len(groups) and set(groups) == {"a", "b", "c"}
    assert all(s["grid"].shape[0] == 3 + len(est.candidates) for s in samples)


def test_mirrored_context_sampling_matches_flipped_grid():
    net = ContextBlendNet(2, n_context=2, widths=(4,), width=4, layers=1)
    feats = torch.arange(2 * 3 * 5, dtype=torch.float32).reshape(2, 3, 5)
    rows = torch.tensor([0, 7, 12, 20]), torch.tensor([3, 10, 30, 39])
    width = 5 * CELL
    direct = net.sample(feats, rows[0], rows[1])
    mirrored = net.sample(feats.flip(-1), rows[0], width - 1 - rows[1])
    torch.testing.assert_close(direct, mirrored)


@pytest.mark.parametrize("kwargs, match", [
    ({"n_context": 0}, "n_context must be an integer >= 1"),
    ({"context_widths": ()}, "context_widths must be a non-empty tuple"),
    ({"context_widths": (4, 0)}, "context_widths must be a non-empty tuple"),
    ({"balance": 2.0}, r"balance must be a number in \[0, 1\]"),
    ({"batch_frames": 0}, "batch_frames must be an integer >= 1"),
    ({"n_members": 0}, "n_members must be an integer >= 1"),
    ({"member_samples": "each"}, r"^member_samples must be one of \('shared', 'own'\), got 'each'$"),
])
def test_bad_parameters(kwargs, match):
    with pytest.raises(ValueError, match=match):
        ContextBlendInpainter(**{**TINY, **kwargs}).fit(_streets(2))


def test_pixel_blend_extra_inputs_are_checked():
    net = PixelBlendNet(2, 4, 4, 1, n_endpoints=4, relative=True, n_extra=3)
    channels = torch.rand(10, 7) + 0.5
    with pytest.raises(ValueError, match=r"expected extra inputs \(3, 7\)"):
        net.blend_channels(channels)
    assert net.blend_channels(channels, torch.zeros(3, 7)).shape == (7,)
