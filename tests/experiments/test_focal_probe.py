"""experiments/focal_probe.py: nearest-neighbour resampling of ground truth and the per-scale headline."""

from __future__ import annotations

import json

import numpy as np
import pytest

from inpaintenv.data import ArrayDataset


def test_resampling_moves_measured_depths_and_never_blends_them(load_experiment):
    script = load_experiment("focal_probe")
    rng = np.random.default_rng(0)
    frames = np.where(rng.random((2, 40, 100)) < 0.3, 1 + 50 * rng.random((2, 40, 100)), 0).astype(np.float32)
    data = script.Resampled(ArrayDataset(frames), 0.77)
    assert data.frame_shape == (31, 77) and len(data) == 2
    small = data[1]
    assert small.shape == (31, 77) and small.dtype == np.float32
    assert set(np.unique(small)) <= set(np.unique(frames[1]))  # every value is a source value
    assert abs((small > 0).mean() - (frames[1] > 0).mean()) < 0.05  # density of the source
    assert np.array_equal(script.Resampled(ArrayDataset(frames), 1.0)[0], frames[0])
    big = script.Resampled(ArrayDataset(frames), 2.0)[0]
    assert np.array_equal(big[::2, ::2], frames[0]) and np.array_equal(big[1::2, 1::2], frames[0])
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(ValueError, match="scale must be"):
            script.Resampled(ArrayDataset(frames), bad)


def test_probe_prints_one_ratio_per_scale(tiny_kitti, tmp_path, capsys, load_experiment):
    script = load_experiment("focal_probe")
    out = tmp_path / "probe.json"
    entries = script.main(["--kitti-root", str(tiny_kitti), "--drive", "2011_09_26_drive_9001_sync", "pretrained",
                           "-m", "harmonic", "-m", "scanline", "--scale", "1", "--scale", "0.5", "--seed", "0",
                           "--out", str(out)])
    assert [e["scale"] for e in entries] == [1.0, 0.5]
    assert [e["frame_shape"] for e in entries] == [[352, 1216], [176, 608]]
    assert all(e["learned"] == "pretrained" and e["classical"] in ("harmonic", "scanline") for e in entries)
    assert all(np.isclose(e["hole_ratio"], e["learned_hole_rmse"] / e["classical_hole_rmse"]) for e in entries)
    assert json.loads(out.read_text())[1]["frame_shape"] == [176, 608]
    assert "| 0.5 | 608×176 | pretrained" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        script.main(["--kitti-root", str(tiny_kitti), "pretrained", "-m", "pretrained"])
