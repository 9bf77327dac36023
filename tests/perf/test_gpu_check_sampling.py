"""perf/gpu_check.py --sample-device train: the rows' samples made as sample_device="train" does (on the CPU here)."""

from __future__ import annotations

import math

import pytest


@pytest.fixture(scope="module")
def gc(load_benchmark):
    return load_benchmark("gpu_check")


def test_sample_device_train_rows_say_so_and_train_on_the_same_samples(gc, capsys):
    summary = gc.main(["--quick", "--skip-tests", "--sample-device", "train"])
    out = capsys.readouterr().out
    assert "1 loader workers, samples made on the device" in out
    assert "train batch=2 bf16 workers=0 sampled on the device: " in out
    rows = summary["training"]
    assert [r["sample_device"] for r in rows] == ["train"] * 3 and all("error" not in r for r in rows)
    # Same seeded network, same samples from either path: the same loss after the same steps.
    cfg, pool = gc.preset_config(), gc.SyntheticStreets(n=4, seed=0, frame_shape=(64, 192)).load_batch(range(4))
    kw = dict(warmup=1, max_steps=2, seconds=0.0, workers=0, peak=None)
    on_device = gc.measure_training(cfg, pool, 2, False, gc.torch.device("cpu"), sample_device="train", **kw)
    in_loader = gc.measure_training(cfg, pool, 2, False, gc.torch.device("cpu"), **kw)
    assert in_loader["sample_device"] == "cpu" and math.isfinite(in_loader["final_loss"])
    assert on_device["final_loss"] == in_loader["final_loss"]
