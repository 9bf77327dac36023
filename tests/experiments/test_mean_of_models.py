"""experiments/mean_of_models.py: two learned models and their per-pixel mean on the same frames."""

from __future__ import annotations

import numpy as np
import pytest


class _Constant:
    def __init__(self, value: float) -> None:
        self.value = value

    def predict(self, depth: np.ndarray) -> np.ndarray:
        return np.where(np.isnan(depth), self.value, depth).astype(np.float32)


def test_mean_is_the_per_pixel_average_of_the_members(load_experiment):
    script = load_experiment("mean_of_models")
    depth = np.full((2, 4, 5), np.nan, np.float32)
    depth[:, 0] = 7.0
    mean = script.MeanOfModels([_Constant(2.0), _Constant(6.0)]).predict(depth)
    assert mean.shape == depth.shape and mean.dtype == np.float32
    assert np.all(mean[:, 1:] == 4.0) and np.all(mean[:, 0] == 7.0)
    with pytest.raises(ValueError, match="at least two models"):
        script.MeanOfModels([_Constant(1.0)])


def test_scores_both_models_and_their_mean_on_one_day(tiny_kitti, capsys, load_experiment):
    script = load_experiment("mean_of_models")
    entries = script.main(["--kitti-root", str(tiny_kitti), "--day", "2011_09_26", "pretrained", "kitti-rect-v4",
                           "-m", "harmonic", "-m", "scanline", "--seed", "0"])
    assert [e["learned"] for e in entries] == ["pretrained", "kitti-rect-v4", "mean"]
    assert all(e["hole_ratio_n"] == 3 for e in entries)  # the day's three one-frame drives
    out = capsys.readouterr().out
    assert "| mean |" in out and "| pretrained |" in out
    for bad in (["pretrained", "kitti-rect-v4"], ["pretrained", "kitti-rect-v4", "-m", "pretrained"],
                ["pretrained", "kitti-rect-v4", "-m", "harmonic", "--day", "1999_01_01"]):
        with pytest.raises(SystemExit):
            script.main(["--kitti-root", str(tiny_kitti), *bad])
