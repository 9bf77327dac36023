"""experiments/selection_frames.py score on the real selection frames (cheap methods only)."""

from __future__ import annotations

import numpy as np
import pytest


@pytest.fixture(scope="module")
def sel_module(load_experiment):
    return load_experiment("selection_frames")


def test_scores_classical_methods_per_protocol(sel_module, kitti_root, capsys):
    rows = sel_module.main(["score", "--kitti-root", str(kitti_root), "-m", "constant", "-m", "scanline",
                            "--protocol", "rect-v1", "--protocol", "ego-occlusion-v1"])
    assert [r["name"] for r in rows] == ["constant", "scanline"]
    for row in rows:
        assert set(row) == {"name", "rect-v1", "ego-occlusion-v1"}
        for hole, whole in (row["rect-v1"], row["ego-occlusion-v1"]):
            assert 0 < whole < hole  # all-pixel RMSE averages in the easy measured pixels
    const, scan = rows
    assert scan["rect-v1"][0] < const["rect-v1"][0]  # interpolation beats the median
    assert '"name": "scanline"' in capsys.readouterr().out


def test_plus_averages_models(sel_module, monkeypatch):
    calls = []

    def fake_load(label):
        calls.append(label)
        return type("Est", (), {"set_params": lambda self, **kw: self,
                                "predict": lambda self, x, v=float(len(calls)): x * 0 + v})()

    monkeypatch.setattr(sel_module, "shipped", lambda: {"a": "BlendInpainter"})
    monkeypatch.setattr(sel_module, "load_release", fake_load)
    monkeypatch.setattr(sel_module, "load", lambda path: fake_load(f"folder {path}"))
    predict = sel_module.batch_predictor("a+b", "model")
    assert calls == ["a", "folder b"]  # a release by name, anything else a saved model folder
    np.testing.assert_array_equal(predict(np.zeros((1, 2, 2))), np.full((1, 2, 2), 1.5))
    with pytest.raises(ValueError, match="kind"):
        sel_module.batch_predictor("x", "other")
