"""experiments/nconv_probe.py: the normalized-convolution network probe of issue 15."""

from __future__ import annotations

import json

import numpy as np
import pytest

torch = pytest.importorskip("torch")


@pytest.fixture(scope="module")
def nconv(load_experiment):
    return load_experiment("nconv_probe")


def test_nconv_layer_is_a_confidence_weighted_mean(nconv):
    torch.manual_seed(0)
    layer = nconv.NConv2d(1, 3, 5)
    x = torch.full((1, 1, 20, 30), 7.0)
    c = (torch.rand(1, 1, 20, 30) > 0.6).float()
    x_garbage = torch.where(c > 0, x, torch.full_like(x, 1e6))  # unconfident pixels must not count
    out, conf = layer(x_garbage, c)
    covered = conf > 0
    assert torch.allclose(out[covered], torch.tensor(7.0), atol=1e-3)
    assert conf.min() >= 0 and conf.max() <= 1 + 1e-6


def test_downsampling_keeps_the_most_confident_pixel(nconv):
    x = torch.arange(16.0).view(1, 1, 4, 4)
    c = torch.zeros(1, 1, 4, 4)
    c[0, 0, 1, 0] = 1.0  # top-left block: pixel (1, 0) holds value 4
    c[0, 0, 3, 3] = 0.5  # bottom-right block: pixel (3, 3) holds value 15
    x_down, c_down = nconv._down(x, c)
    assert x_down[0, 0, 0, 0] == 4 and x_down[0, 0, 1, 1] == 15
    assert c_down[0, 0, 0, 0] == 1 and c_down[0, 0, 1, 1] == 0.5 and c_down[0, 0, 0, 1] == 0


def test_untrained_net_fills_a_hole_in_a_constant_scene_with_that_depth(nconv):
    torch.manual_seed(0)
    net = nconv.NConvNet(channels=2, scales=3).eval()
    x = np.where(np.random.default_rng(0).random((48, 64)) < 0.4, 12.0, 0.0).astype(np.float32)
    x[10:30, 20:50] = np.nan
    out = nconv.predict(net, x)
    assert out.shape == x.shape and np.isfinite(out).all()
    assert np.allclose(out[10:30, 20:50], 12.0, rtol=1e-3)  # bias 0 at start: a weighted mean of 12 m
    known = np.nan_to_num(x) > 0
    assert np.array_equal(out[known], x[known])  # measured pixels kept


@pytest.mark.slow
def test_main_scores_each_held_out_drive_and_the_official_frame(nconv, tiny_kitti, tmp_path):
    out = tmp_path / "nconv.json"
    results = nconv.main(["--kitti-root", str(tiny_kitti), "--steps", "2", "--batch", "1", "--channels", "2",
                          "--scales", "3", "--seeds", "0", "--folds", "2011_09_26_drive_9002_sync",
                          "--json", str(out)])
    assert set(results) == {"2011_09_26_drive_9002_sync",
                            "2011_10_03_drive_9101_sync (model without 2011_09_26_drive_9002_sync)"}
    for row in results.values():
        assert row["ratio"] > 0 and row["ci"][0] <= row["ratio"] <= row["ci"][1]
        assert row["classical"] in nconv.CLASSICAL and row["predict_ms"] > 0
    assert json.loads(out.read_text()) == results
