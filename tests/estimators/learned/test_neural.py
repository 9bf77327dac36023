"""UNetInpainter / AutoencoderInpainter: fit, predict, persistence, resume, warm start."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch
from sklearn.base import clone
from sklearn.exceptions import NotFittedError

from estimators.learned._output import MIN_HOLE_DEPTH
from estimators.learned import AutoencoderInpainter, UNetInpainter
from inpaintenv.exceptions import CheckpointError
from inpaintenv.data import ArrayDataset
from inpaintenv.data.base import DepthDataset, split_by_drive
from training_helpers import interrupt_after

H, W = 24, 40


def tiny(cls=UNetInpainter, **kw):
    """A model that trains in well under a second on CPU."""
    params = {"width": 4, "depth": 2, "batch_size": 2, "epochs": 1, "random_state": 0, "num_threads": 1}
    return cls(**(params | kw))


@pytest.fixture(scope="module")
def frames() -> np.ndarray:
    rng = np.random.default_rng(0)
    rows = np.linspace(30.0, 5.0, H, dtype=np.float32)[:, None]
    out = np.stack([rows + k + np.zeros((1, W), np.float32) for k in range(6)])
    out[rng.random(out.shape) < 0.3] = 0.0
    return out


@pytest.fixture(scope="module")
def dataset(frames) -> ArrayDataset:
    return ArrayDataset(frames, groups=["a", "a", "b", "b", "c", "c"])


@pytest.fixture(scope="module")
def corrupted(frames) -> np.ndarray:
    x = frames[:2].copy()
    x[:, 4:12, 8:30] = np.nan
    return x


@pytest.fixture(scope="module")
def fitted(dataset) -> UNetInpainter:
    return tiny(epochs=2).fit(dataset)


def test_not_fitted_errors(corrupted, tmp_path):
    est = tiny()
    with pytest.raises(NotFittedError):
        est.predict(corrupted)
    with pytest.raises(NotFittedError):
        est.save(tmp_path / "m")


def test_fit_predict_contract(fitted, corrupted):
    out = fitted.predict(corrupted)
    assert out.shape == corrupted.shape and out.dtype == np.float32
    assert np.isfinite(out).all() and (out >= 0).all()
    observed = corrupted > 0
    assert np.array_equal(out[observed], corrupted[observed])
    assert fitted.predict(corrupted[0]).shape == (H, W)
    # 6 frames, batch 2, 2 epochs.
    assert fitted.n_steps_ == 6
    assert len(fitted.history_["step_loss"]) == 6 and len(fitted.history_["epoch_loss"]) == 2
    assert fitted.history_["val_hole_rmse"] == [] and fitted.history_["best_epoch"] is None


def test_any_frame_size_predicts(fitted):
    x = np.full((1, 37, 53), 10.0, np.float32)
    x[0, 5:20, 5:20] = np.nan
    assert fitted.predict(x).shape == x.shape


def test_same_seed_same_model(dataset, corrupted, fitted):
    again = tiny(epochs=2).fit(dataset)
    assert np.array_equal(again.predict(corrupted), fitted.predict(corrupted))
    other = tiny(epochs=2, random_state=1).fit(dataset)
    assert not np.array_equal(other.predict(corrupted), fitted.predict(corrupted))


def test_fit_restores_torch_threads(dataset):
    before = torch.get_num_threads()
    est = tiny(num_threads=1).fit(dataset)
    assert est.n_threads_ == 1
    assert torch.get_num_threads() == before


def test_autoencoder_and_mask_input(dataset, corrupted):
    ae = tiny(AutoencoderInpainter, input_mask=True).fit(dataset)
    assert ae.model_.skip is False and ae.model_.in_channels == 3
    assert np.isfinite(ae.predict(corrupted)).all()


def test_cpu_bf16_and_channels_last_run(dataset, corrupted):
    for kw in ({"amp": "cpu-bf16"}, {"channels_last": True}):
        out = tiny(max_steps=1, **kw).fit(dataset).predict(corrupted)
        assert np.isfinite(out).all()


def test_validation_split_selects_best_epoch(dataset):
    est = tiny(epochs=3, validation_fraction=0.34).fit(dataset)
    val = est.history_["val_hole_rmse"]
    assert len(val) == 3 and all(v > 0 for v in val)
    assert est.history_["best_epoch"] == int(np.nanargmin(val))


def test_validation_needs_two_drives(frames):
    one_drive = ArrayDataset(frames, groups=["a"] * len(frames))
    with pytest.raises(ValueError, match="at least 2 drives"):
        tiny(validation_fraction=0.5).fit(one_drive)


def test_max_steps_stops_mid_epoch(dataset):
    assert tiny(epochs=5, max_steps=4).fit(dataset).n_steps_ == 4


def test_crop_trains_on_crops(dataset, monkeypatch):
    seen = []
    from estimators.learned import _neural as neural

    orig = neural._NeuralInpainter._train_step

    def spy(self, model, optimisation, gt, hole, device):
        seen.append(tuple(gt.shape))
        return orig(self, model, optimisation, gt, hole, device)

    monkeypatch.setattr(neural._NeuralInpainter, "_train_step", spy)
    tiny(crop=(16, 1000), max_steps=1).fit(dataset)
    assert seen == [(2, 16, W)]  # width clipped to the frame


# -- persistence ---------------------------------------------------------------------
def test_save_load_round_trip(fitted, corrupted, tmp_path):
    path = fitted.save(tmp_path / "model")
    assert {p.name for p in path.iterdir()} == {"model.safetensors", "config.json"}
    loaded = UNetInpainter.load(path)
    assert type(loaded) is UNetInpainter
    assert loaded.get_params() == fitted.get_params()
    assert np.array_equal(loaded.predict(corrupted), fitted.predict(corrupted))
    assert loaded.history_ == fitted.history_ and loaded.n_steps_ == fitted.n_steps_
    config = json.loads((path / "config.json").read_text())
    assert config["class"] == "UNetInpainter" and config["params"]["width"] == 4


def test_load_checks_class(fitted, tmp_path):
    path = fitted.save(tmp_path / "model")
    with pytest.raises(CheckpointError, match="not a AutoencoderInpainter"):
        AutoencoderInpainter.load(path)


@pytest.mark.parametrize("damage", ["truncate", "flip", "bad_json", "missing"])
def test_corrupt_checkpoint_gives_clear_error(fitted, tmp_path, damage):
    path = fitted.save(tmp_path / "model")
    weights = path / "model.safetensors"
    if damage == "truncate":
        weights.write_bytes(weights.read_bytes()[:100])
    elif damage == "flip":
        data = bytearray(weights.read_bytes())
        data[-5] ^= 0xFF
        weights.write_bytes(bytes(data))
    elif damage == "bad_json":
        (path / "config.json").write_text('{"format": "inpaint')
    else:
        weights.unlink()
    with pytest.raises(CheckpointError, match="truncated|corrupt|missing"):
        UNetInpainter.load(path)


def test_load_nonexistent(tmp_path):
    with pytest.raises(CheckpointError, match="no checkpoint"):
        UNetInpainter.load(tmp_path / "nope")


# -- checkpoints during training and resume ------------------------------------------------
def _interrupt_after(monkeypatch, n_steps):
    from estimators.learned import _neural as neural

    interrupt_after(monkeypatch, neural._NeuralInpainter, n_steps)


def test_resume_equals_uninterrupted_run(dataset, corrupted, tmp_path, monkeypatch):
    kw = {"epochs": 3, "validation_fraction": 0.34, "checkpoint_every": 1}
    full = tiny(**kw, checkpoint_dir=tmp_path / "a").fit(dataset)

    with monkeypatch.context() as m:
        _interrupt_after(m, 3)  # mid-epoch 2 (2 training drives -> 2 steps per epoch)
        with pytest.raises(KeyboardInterrupt):
            tiny(**kw, checkpoint_dir=tmp_path / "b").fit(dataset)
    (run,) = (tmp_path / "b").iterdir()
    state = json.loads((run / "state.json").read_text())
    assert state["last"].startswith("ckpt-00000003")

    resumed = tiny(**kw, checkpoint_dir=tmp_path / "b").fit(dataset)
    assert resumed.n_steps_ == full.n_steps_ == 6
    assert resumed.history_ == full.history_
    assert np.array_equal(resumed.predict(corrupted), full.predict(corrupted))


def test_finished_run_is_not_retrained(dataset, corrupted, tmp_path, monkeypatch):
    first = tiny(checkpoint_dir=tmp_path).fit(dataset)
    from estimators.learned import _neural as neural

    def fail(*a):
        raise AssertionError("should not train again")

    monkeypatch.setattr(neural._NeuralInpainter, "_train_step", fail)
    again = tiny(checkpoint_dir=tmp_path, verbose=True).fit(dataset)  # verbose does not change the run
    assert again.run_dir_ == first.run_dir_
    assert np.array_equal(again.predict(corrupted), first.predict(corrupted))
    # The run directory also loads as a model (its best, else last, checkpoint).
    assert np.array_equal(UNetInpainter.load(first.run_dir_).predict(corrupted), first.predict(corrupted))


def test_run_dirs_differ_by_params_and_data(dataset, tmp_path):
    a = tiny(max_steps=1, checkpoint_dir=tmp_path).fit(dataset)
    b = tiny(max_steps=1, checkpoint_dir=tmp_path, hole_weight=1.0).fit(dataset)
    c = tiny(max_steps=1, checkpoint_dir=tmp_path).fit(dataset[:4])
    assert len({a.run_dir_, b.run_dir_, c.run_dir_}) == 3


def test_corrupt_last_checkpoint_stops_resume_with_clear_error(dataset, tmp_path):
    est = tiny(checkpoint_dir=tmp_path).fit(dataset)
    state = json.loads((est.run_dir_ / "state.json").read_text())
    (est.run_dir_ / state["last"] / "optimizer.safetensors").write_bytes(b"garbage")
    with pytest.raises(CheckpointError, match="optimizer.safetensors"):
        tiny(checkpoint_dir=tmp_path).fit(dataset)


# -- warm start --------------------------------------------------------------------------
def test_warm_start_copies_encoder(dataset, tmp_path):
    ae = tiny(AutoencoderInpainter, epochs=2).fit(dataset)
    for source in (ae, ae.save(tmp_path / "ae")):
        # One step with a negligible learning rate: weights are still the initial ones.
        unet = tiny(warm_start=source, max_steps=1, lr=1e-12).fit(dataset)
        for k, v in ae.model_.encoder.state_dict().items():
            torch.testing.assert_close(unet.model_.encoder.state_dict()[k], v, atol=1e-9, rtol=0)
    cold = tiny(max_steps=1, lr=1e-12, random_state=5).fit(dataset)
    k = next(iter(ae.model_.encoder.state_dict()))
    assert not torch.allclose(cold.model_.encoder.state_dict()[k], ae.model_.encoder.state_dict()[k])


def test_warm_start_errors(dataset):
    ae = tiny(AutoencoderInpainter, max_steps=1).fit(dataset)
    with pytest.raises(ValueError, match="does not match"):
        tiny(warm_start=ae, width=8, max_steps=1).fit(dataset)
    with pytest.raises(ValueError, match="not fitted"):
        tiny(warm_start=clone(ae), max_steps=1).fit(dataset)
    with pytest.raises(TypeError, match="warm_start"):
        tiny(warm_start=3, max_steps=1).fit(dataset)


# -- validation ---------------------------------------------------------------------------
@pytest.mark.parametrize(
    "bad, match",
    [
        ({"width": 0}, "width"),
        ({"depth": 1.5}, "depth"),
        ({"batch_size": 0}, "batch_size"),
        ({"crop": (0, 4)}, "crop"),
        ({"crop": 16}, "crop"),
        ({"amp": "fp8"}, "amp"),
        ({"validation_fraction": 1.5}, "validation_fraction"),
        ({"lr": -1.0}, "lr"),
        ({"hole_weight": float("nan")}, "hole_weight"),
        ({"random_state": -1}, "random_state"),
        ({"depth_scale": "log"}, "depth_scale"),
        ({"compile": "fast"}, "compile"),
        ({"compile": 1}, "compile"),
        ({"device": "cuda" if not torch.cuda.is_available() else "nonsense"}, "device"),
        ({"max_depth": 1e-30}, r"^max_depth must be a number in \[0.1, 100000\], got 1e-30$"),
        ({"max_depth": 1e9}, r"^max_depth must be a number in \[0.1, 100000\], got 1000000000.0$"),
        ({"max_depth": float("inf")}, r"^max_depth must be a number in \[0.1, 100000\], got inf$"),
        ({"device": "meta"}, r"device must be one of 'auto', 'cpu', 'cuda', 'cuda:N' or 'mps', got 'meta'"),
        ({"device": "cuda:7"}, r"device='cuda:7' but (no CUDA device is available|only \d CUDA device)"),
        ({"width": 4, "depth": 12}, r"width=4, depth=12 gives 16384 channels at the deepest level \(width \* 2\*\*depth\), more than the 2048 allowed"),
        ({"width": 256, "depth": 4}, r"width=256, depth=4 .* more than the 2048 allowed"),
        ({"depth": 10**9}, r"depth=1000000000 gives"),
        ({"depth": 5}, r"depth=5 \(2\*\*depth = 32 px\) needs training frames of at least 32 px per side, got 24x40"),
        ({"depth": 4, "crop": (8, 64)}, r"needs training crops of at least 16 px per side, got 8x40"),
    ],
)
def test_bad_parameters_rejected_at_fit(dataset, bad, match):
    with pytest.raises(ValueError, match=match):
        tiny(**bad).fit(dataset)


# -- torch.compile ------------------------------------------------------------------------
@pytest.mark.slow
def test_compiled_training_and_prediction_match_eager(dataset, corrupted):
    """compile= routes training steps and prediction through torch.compile; same numbers.

    ``aot_eager`` traces forward and backward graphs like the default inductor backend
    but runs them with eager kernels, so the test is quick and exact; inductor itself
    (minutes of C++ compilation on CPU) is measured in perf/bench_neural.py.
    """
    eager = tiny(max_steps=3).fit(dataset)
    compiled = tiny(max_steps=3, compile={"backend": "aot_eager"}).fit(dataset)
    np.testing.assert_allclose(compiled.history_["step_loss"], eager.history_["step_loss"], rtol=1e-5)
    np.testing.assert_allclose(compiled.predict(corrupted), eager.predict(corrupted), rtol=1e-4, atol=1e-3)
    # numpy booleans (as from a parameter grid) mean the same as Python's.
    assert tiny(compile=np.False_)._compiled(eager.model_) is eager.model_
    assert tiny(compile=np.True_)._compiled(eager.model_) is not eager.model_
    # Weights are the plain module's: the checkpoint keys carry no "_orig_mod." prefix.
    assert not any(k.startswith("_orig_mod") for k in compiled.model_.state_dict())


# -- depth scale ------------------------------------------------------------------------
def test_frame_depth_scale_is_scale_equivariant(dataset, corrupted):
    """With depth_scale="frame" a scene twice as far gets a fill exactly twice as far."""
    est = tiny(depth_scale="frame", input_mask=True, keep_observed=False, max_steps=2).fit(dataset)
    near, far = est.predict(corrupted), est.predict(2 * corrupted)
    # Below the floor of hole pixels (MIN_HOLE_DEPTH, the same for both) nothing scales.
    scaled = near > MIN_HOLE_DEPTH
    assert scaled.mean() > 0.5
    np.testing.assert_allclose(far[scaled], 2 * near[scaled], rtol=1e-5)
    # The study's fixed 80 m scale is not equivariant (GroupNorm + conv bias see the level).
    study = tiny(keep_observed=False, max_steps=2).fit(dataset)
    assert not np.allclose(study.predict(2 * corrupted), 2 * study.predict(corrupted), rtol=1e-3)


def test_frame_depth_scale_survives_frames_with_nothing_observed(dataset):
    est = tiny(depth_scale="frame", max_steps=1).fit(dataset)
    empty = np.zeros((1, H, W), np.float32)
    empty[0, 4:12, 8:30] = np.nan  # only a hole and unmeasured pixels
    pred = est.predict(empty)
    assert np.isfinite(pred).all() and pred.shape == empty.shape


def test_unknown_protocol(dataset):
    with pytest.raises(KeyError, match="unknown occlusion protocol"):
        tiny(protocol="nope").fit(dataset)


def test_bad_input_errors_come_from_base_validation(fitted, frames):
    with pytest.raises(ValueError, match="no NaN"):
        fitted.predict(frames[:1])
    with pytest.raises(ValueError, match="2-D or 3-D"):
        fitted.predict(np.zeros(5, np.float32))
    with pytest.raises(ValueError, match="infinite"):
        fitted.predict(np.full((4, 4), np.inf, np.float32))
    with pytest.raises(ValueError, match="negative"):
        tiny().fit(-frames)


def _copy(fitted):
    """An independent fitted copy (clone() drops fitted state)."""
    est = clone(fitted)
    est.__dict__.update({k: v for k, v in vars(fitted).items() if k.endswith("_")})
    return est


@pytest.mark.parametrize(
    "change, match",
    [
        ({"max_depth": 20.0}, r"^max_depth=20.0 differs from the 80.0 this model was trained with; refit or set it back$"),
        ({"width": 8}, r"^width=8 differs from the 4 this model was trained with"),
        ({"depth": 1}, r"^depth=1 differs from the 2 "),
        ({"depth_scale": "frame"}, r"^depth_scale='frame' differs from the 'fixed' "),
        ({"input_mask": True}, r"^input_mask=True differs from the False "),
    ],
)
def test_model_params_changed_after_fit_raise(fitted, corrupted, tmp_path, change, match):
    est = _copy(fitted)
    before = est.predict(corrupted)
    est.set_params(**change)
    with pytest.raises(ValueError, match=match):
        est.predict(corrupted)
    with pytest.raises(ValueError, match=match):
        est.save(tmp_path / "m")  # would write a config that does not describe the weights
    est.set_params(**{k: fitted.get_params()[k] for k in change})
    np.testing.assert_array_equal(est.predict(corrupted), before)


def test_training_and_prediction_params_may_change_after_fit(fitted, corrupted, tmp_path):
    est = _copy(fitted)
    before = est.predict(corrupted)
    est.set_params(lr=1.0, max_steps=1, epochs=3, hole_weight=0.0, batch_size=1, device="cpu",
                   num_threads=2, verbose=True, checkpoint_dir=tmp_path)
    np.testing.assert_array_equal(est.predict(corrupted), before)
    loaded = UNetInpainter.load(est.save(tmp_path / "m"))
    assert loaded.model_params_ == fitted.model_params_
    np.testing.assert_array_equal(loaded.predict(corrupted), before)
    with pytest.raises(ValueError, match="max_depth=40.0 differs from the 80.0"):
        loaded.set_params(max_depth=40.0).predict(corrupted)


def test_refit_after_changing_model_params_records_them(fitted, dataset, corrupted):
    est = clone(fitted).set_params(width=8, max_depth=40.0, max_steps=1)
    assert est.fit(dataset).model_params_["width"] == 8
    assert est.model_params_["max_depth"] == 40.0 and est.predict(corrupted).shape == corrupted.shape


def test_device_is_checked_at_predict(fitted, corrupted):
    est = _copy(fitted)
    with pytest.raises(TypeError, match=r"device must be one of .*, got 3"):
        est.set_params(device=3).predict(corrupted)
    with pytest.raises(ValueError, match="got 'meta'"):
        est.set_params(device="meta").predict(corrupted)
    assert est.set_params(device="cpu").predict(corrupted).shape == corrupted.shape


def test_frames_as_small_as_the_downsampling_train(frames):
    # 24 px tall frames: depth=3 (8 px) is fine, and predict still takes any size.
    est = tiny(depth=3, max_steps=1).fit(frames)
    assert est.predict(np.where(frames[:1] > 20, np.nan, frames[:1])).shape == (1, H, W)


class _Frames(DepthDataset):
    """A custom dataset that, unlike ArrayDataset, does not validate its frames."""

    def __init__(self, frames):
        self._frames = frames
        self.frame_shape = frames.shape[1:]
        self.groups = np.array(["a", "a", "b", "b", "c", "c"][: len(frames)])
        self.frame_ids = [f"custom/{i}" for i in range(len(frames))]

    def _load(self, index):
        return self._frames[index]


@pytest.mark.parametrize(
    "value, match",
    [(np.nan, r"training frame 3 \(id 'custom/3'\) contains NaN"),
     (-1.0, r"training frame 3 \(id 'custom/3'\) contains negative depth"),
     (np.inf, r"training frame 3 \(id 'custom/3'\) contains infinite")],
)
def test_every_training_frame_is_validated(frames, value, match):
    # Frame 0 is fine, so only a per-frame check at load time catches frame 3.
    bad = frames.copy()
    bad[3, 5, 5] = value
    with pytest.raises(ValueError, match=match):
        tiny(max_steps=3).fit(_Frames(bad))


def test_validation_frames_are_validated(frames):
    # NaN only in frames of the held-out drive (not frame 0, which fit checks up front).
    held_out = set(split_by_drive(_Frames(frames), 0.3, seed=0)[1].frame_ids)
    bad = frames.copy()
    idx = [i for i in range(1, len(frames)) if f"custom/{i}" in held_out]
    assert idx and "custom/0" not in held_out
    bad[idx, 5, 5] = np.nan
    with pytest.raises(ValueError, match=r"validation frame \d \(id 'custom/\d'\) contains NaN"):
        tiny(max_steps=3, validation_fraction=0.3).fit(_Frames(bad))


def test_warm_start_true_continues_previous_fit(dataset):
    est = tiny(max_steps=2).fit(dataset)
    before = {k: v.clone() for k, v in est.model_.state_dict().items()}
    est.set_params(warm_start=True, lr=1e-12, max_steps=1).fit(dataset)
    for k, v in est.model_.state_dict().items():
        torch.testing.assert_close(v, before[k], atol=1e-9, rtol=0)
    # False behaves like None: a fresh initialisation.
    fresh = tiny(max_steps=1, lr=1e-12, warm_start=False).fit(dataset)
    assert not all(torch.equal(fresh.model_.state_dict()[k], v) for k, v in before.items())


def test_loader_workers_give_the_same_model(dataset, corrupted, fitted):
    # Samples are seeded by (seed, epoch, index), not by the worker that loads them.
    with_workers = tiny(epochs=2, num_workers=2).fit(dataset)
    assert np.array_equal(with_workers.predict(corrupted), fitted.predict(corrupted))
