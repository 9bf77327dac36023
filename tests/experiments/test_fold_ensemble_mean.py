"""experiments/fold_ensemble.py mean: two learned models and their per-pixel mean on the same frames."""

from __future__ import annotations

import numpy as np
import pytest


class _Constant:
    def __init__(self, value: float) -> None:
        self.value = value

    def predict(self, depth: np.ndarray) -> np.ndarray:
        return np.where(np.isnan(depth), self.value, depth).astype(np.float32)


def test_mean_is_the_per_pixel_average_of_the_members(load_experiment):
    script = load_experiment("fold_ensemble")
    depth = np.full((2, 4, 5), np.nan, np.float32)
    depth[:, 0] = 7.0
    mean = script.MeanOfModels([_Constant(2.0), _Constant(6.0)]).predict(depth)
    assert mean.shape == depth.shape and mean.dtype == np.float32
    assert np.all(mean[:, 1:] == 4.0) and np.all(mean[:, 0] == 7.0)
    with pytest.raises(ValueError, match="at least two models"):
        script.MeanOfModels([_Constant(1.0)])


def test_scores_both_models_and_their_mean_on_one_day(tiny_kitti, capsys, load_experiment):
    script = load_experiment("fold_ensemble")
    entries = script.main(["mean", "--kitti-root", str(tiny_kitti), "--day", "2011_09_26", "pretrained", "kitti-mixed-v1",
                           "-m", "harmonic", "-m", "scanline", "--seed", "0"])
    assert [e["learned"] for e in entries] == ["pretrained", "kitti-mixed-v1", "mean"]
    assert all(e["hole_ratio_n"] == 3 for e in entries)  # the day's three one-frame drives
    out = capsys.readouterr().out
    assert "| mean |" in out and "| pretrained |" in out
    for bad in (["pretrained", "kitti-mixed-v1"], ["pretrained", "kitti-mixed-v1", "-m", "pretrained"],
                ["pretrained", "kitti-mixed-v1", "-m", "harmonic", "--day", "1999_01_01"]):
        with pytest.raises(SystemExit):
            script.main(["mean", "--kitti-root", str(tiny_kitti), *bad])


def _default_members() -> list:
    """The two blend models of the shipped default (they read the same candidate features)."""
    from estimators.learned import load_release

    members = load_release("kitti-ensemble-v1").named_estimators_
    return [members["context"], members["blend"]]


def test_shared_features_give_the_mean_of_the_two_predictions(load_experiment):
    from inpaintenv.conventions import corrupt
    from inpaintenv.data import SyntheticStreets
    from inpaintenv.masks import get_protocol

    script = load_experiment("fold_ensemble")
    gt = SyntheticStreets(n=1, frame_shape=(96, 320))[0]
    x = corrupt(gt, get_protocol("rect-v1").mask(gt.shape, seed=0, index=0))
    models = _default_members()
    separate = script.MeanOfModels(models).predict(x[None])
    shared = script.shared_feature_mean(models).predict(x)
    assert shared.shape == x.shape
    np.testing.assert_allclose(shared, separate[0], rtol=0, atol=1e-5)
    models[1].set_params(candidates=("scanline", "harmonic"))
    with pytest.raises(ValueError, match="same candidate features"):
        script.shared_feature_mean(models)
    with pytest.raises(ValueError, match="need blend estimators; not one: _Constant"):
        script.shared_feature_mean([models[0], _Constant(1.0)])


def test_second_model_parameters_are_checked(tiny_kitti, tmp_path, load_experiment):
    script = load_experiment("fold_ensemble")
    context, blend = _default_members()
    folders = [str(context.save(tmp_path / "context")), str(blend.save(tmp_path / "blend"))]
    base = ["--kitti-root", str(tiny_kitti), "--drive", "2011_09_26_drive_9001_sync", *folders,
            "-m", "scanline", "--seed", "0", "--shared-features"]
    entries = script.main(["mean", *base, "--set-second", "tta=false"])
    assert entries[0]["learned"] == "context" and entries[1]["learned"] == "blend (tta=false)"
    assert entries[2]["learned"] == "mean"
    for bad in ("tta", "tta=notjson", "no_such_param=1"):
        with pytest.raises(SystemExit):
            script.main(["mean", *base, "--set-second", bad])
