"""BlendInpainter: pixel sampling, training, hole-only prediction, persistence, errors."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch
from streets import streets as _streets

from estimators.learned import BlendInpainter, load_release
from estimators.learned._checkpoint import CheckpointError
from estimators.candidates import prior_features
from inpaintenv.data import ArrayDataset

TINY = dict(width=8, layers=1, epochs=2, masks_per_frame=2, pixels_per_frame=200, batch_pixels=128, num_threads=1)


@pytest.fixture(scope="module")
def fitted() -> BlendInpainter:
    return BlendInpainter(**TINY).fit(ArrayDataset(_streets(), groups=list("aabbcc")))


def _corrupt(gt: np.ndarray) -> np.ndarray:
    x = gt.copy()
    x[10:25, 30:70] = np.nan
    return x


def test_fit_learns_more_than_the_candidate_mean(fitted):
    gt = _streets(n=2, seed=5)
    x = np.stack([_corrupt(g) for g in gt])
    hole = np.isnan(x) & (gt > 0)
    untrained = BlendInpainter(**{**TINY, "epochs": 1})
    untrained.model_ = untrained._build_model()  # head starts at zero: the candidates' mean
    untrained.model_params_, untrained.is_fitted_ = untrained._model_params(), True
    err = lambda est: np.sqrt(np.mean((est.predict(x)[hole] - gt[hole]) ** 2))
    assert err(fitted) < err(untrained)
    assert fitted.n_pixels_ > 0 and fitted.training_frames_ == 6
    assert len(fitted.history_["epoch_loss"]) == TINY["epochs"]


def test_network_runs_on_the_pixels_to_fill_only(fitted):
    x = _corrupt(_streets(n=1, seed=3)[0])
    out = fitted.predict(x)
    feats = prior_features(x, fitted.candidates, gaps=True, endpoints=True)
    k = len(fitted.candidates)
    gaps_outside = (x == 0)
    # LiDAR gaps outside the hole: the candidates' mean; measured pixels: kept.
    np.testing.assert_allclose(out[gaps_outside], feats[3:3 + k].mean(0)[gaps_outside], rtol=1e-6)
    np.testing.assert_array_equal(out[x > 0], x[x > 0])
    assert np.isfinite(out).all() and (out[np.isnan(x)] > 0).all()


def test_flip_average_is_mirror_symmetric(fitted):
    x = _corrupt(_streets(n=1, seed=4)[0])
    out = fitted.predict(x)
    mirrored = fitted.predict(x[:, ::-1].copy())[:, ::-1]
    np.testing.assert_allclose(out, mirrored, rtol=1e-4, atol=1e-4)


def test_training_is_reproducible():
    data = ArrayDataset(_streets(n=3))
    a = BlendInpainter(**TINY).fit(data)
    b = BlendInpainter(**TINY).fit(data)
    for p, q in zip(a.model_.parameters(), b.model_.parameters()):
        torch.testing.assert_close(p, q, rtol=0, atol=0)


def test_thinned_copies_add_training_pixels():
    data = ArrayDataset(_streets(n=3))
    one = BlendInpainter(**TINY).training_pixels(data)
    two = BlendInpainter(**{**TINY, "keep": (1.0, 0.5)}).training_pixels(data)
    assert len(two[1]) > len(one[1])
    assert one[0].shape[1] == two[0].shape[1] == 5 + 4 + 4  # candidates, gaps, endpoints


def test_max_pixels_caps_the_pooled_training_pixels():
    data = ArrayDataset(_streets(n=3))  # 3 frames x 2 occlusions x 1 keep x 200 pixels = 1200 at most
    est = BlendInpainter(**{**TINY, "max_pixels": 300})
    with pytest.warns(UserWarning, match="= 1200 training pixels exceed max_pixels=300: sampling 50 pixels per"):
        x, y = est.training_pixels(data)
    assert est.pixels_per_sample_ == 50 and 0 < len(y) <= 300 and len(x) == len(y)


def test_max_pixels_above_the_need_changes_nothing():
    import warnings

    data = ArrayDataset(_streets(n=3))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        capped = BlendInpainter(**{**TINY, "max_pixels": 1200}).training_pixels(data)
    free = BlendInpainter(**{**TINY, "max_pixels": None}).training_pixels(data)
    np.testing.assert_array_equal(capped[0], free[0])
    np.testing.assert_array_equal(capped[1], free[1])


def test_save_load_round_trip(fitted, tmp_path):
    path = fitted.save(tmp_path / "model")
    again = BlendInpainter.load(path)
    x = _corrupt(_streets(n=1, seed=6)[0])
    np.testing.assert_array_equal(again.predict(x), fitted.predict(x))
    assert again.get_params() == fitted.get_params()


def test_changed_architecture_after_fit_is_refused(fitted, tmp_path):
    est = BlendInpainter.load(fitted.save(tmp_path / "model"))
    est.set_params(width=16)
    with pytest.raises(ValueError, match="width changed since the weights were made"):
        est.predict(_corrupt(_streets(n=1)[0]))


def test_load_errors(tmp_path, fitted):
    with pytest.raises(CheckpointError, match="no checkpoint directory"):
        BlendInpainter.load(tmp_path / "nope")
    path = fitted.save(tmp_path / "m")
    (path / "model.safetensors").write_bytes(b"garbage")
    with pytest.raises(CheckpointError, match="checksum"):
        BlendInpainter.load(path)


@pytest.mark.parametrize("params, match", [
    ({"keep": (0.0,)}, "keep must be"),
    ({"keep": "1"}, "keep must be"),
    ({"candidates": ("telepathy",)}, "candidates must be"),
    ({"candidates": "scanline"}, "candidates must be a non-empty tuple"),
    ({"width": 0}, "width must be"),
    ({"lr": float("nan")}, "lr must be"),
    ({"predict_threads": 0}, "predict_threads must be"),
    ({"num_threads": 1.5}, "num_threads must be"),
    ({"max_pixels": 0}, "max_pixels must be"),
    ({"n_jobs": 0}, "n_jobs must be"),
    ({"protocol": "nope"}, "nope"),
])
def test_bad_parameters(params, match):
    with pytest.raises((ValueError, KeyError), match=match):
        BlendInpainter(**{**TINY, **params}).fit(_streets(n=2))


def test_no_ground_truth_in_any_hole_is_a_clear_error():
    with pytest.raises(ValueError, match="no training frame has ground truth"):
        BlendInpainter(**TINY).fit(np.zeros((2, 40, 96), np.float32))


def test_unknown_release_lists_the_shipped_ones():
    with pytest.raises(KeyError, match="no shipped release 'nope'; shipped: .*kitti-ensemble-v1"):
        load_release("nope")


def test_verbose_fit_shows_one_progress_display_of_the_features(capsys):
    # The ~4-minute feature phase printed only joblib's own lines, without a total.
    BlendInpainter(**{**TINY, "epochs": 1}, n_jobs=2, verbose=True).fit(_streets(4))
    err = capsys.readouterr().err
    assert "[Parallel(" not in err
    assert "training features: " in err and "s/frame from its first batch" in err and "for its 4 frames" in err
    assert "training features: 4 frames in " in err  # the closing line, with the time taken


def test_identical_trainings_give_identical_weights_with_threads_and_jobs(tmp_path, monkeypatch):
    # Same machine, same libraries, one process: bit for bit, also with 2 torch threads and
    # 2 feature workers; torch's deterministic algorithms are on during fit only.
    seen = []
    original = BlendInpainter._fit_pixels

    def spy(self, *args):
        seen.append(torch.are_deterministic_algorithms_enabled())
        return original(self, *args)

    monkeypatch.setattr(BlendInpainter, "_fit_pixels", spy)
    data = ArrayDataset(_streets(n=4), groups=["d1", "d1", "d2", "d2"])
    params = {**TINY, "num_threads": 2, "n_jobs": 2}
    a = BlendInpainter(**params).fit(data).save(tmp_path / "a")
    b = BlendInpainter(**params).fit(data).save(tmp_path / "b")
    assert (a / "model.safetensors").read_bytes() == (b / "model.safetensors").read_bytes()
    assert seen == [True, True] and not torch.are_deterministic_algorithms_enabled()
    config = json.loads((a / "config.json").read_text())
    assert config["training_drives"] == ["d1", "d2"]
    env = config["environment"]
    assert env["torch_threads"] == 2 and env["torch_deterministic"] is True
    assert env["versions"]["torch"] == torch.__version__ and env["versions"]["numpy"] == np.__version__
    assert {"python", "platform", "cpu_model", "cpu_count", "torch_interop_threads"} <= set(env)
    assert {"opencv", "scikit-learn"} <= set(env["versions"])
    loaded = BlendInpainter.load(a)
    assert loaded.training_drives_ == ["d1", "d2"] and loaded.fit_environment_ == env


def test_shipped_releases_know_their_training_drives():
    from estimators.learned import load_release

    blend = load_release("kitti-ensemble-v1").named_estimators_["blend"]
    assert isinstance(blend, BlendInpainter) and len(blend.training_drives_) == 15
    assert BlendInpainter(**TINY).fit(_streets(n=2)).training_drives_ is None  # plain arrays name no drive
