"""experiments/selection_frames.py train end to end with the seconds-long smoke preset."""

from __future__ import annotations

import pytest

@pytest.fixture(scope="module")
def selection_module(load_experiment):
    return load_experiment("selection_frames")


def test_trains_on_real_plus_synthetic_frames_and_scores_sel(selection_module, kitti_root, tmp_path):
    row = selection_module.main(["train", "smoke", "--preset", "smoke", "--kitti-root", str(kitti_root),
                                 "--out", str(tmp_path), "--synthetic", "2", "max_steps=1"])
    assert row["synthetic"] == 2 and row["overrides"] == {"max_steps": "1"}
    assert row["sel_hole_rmse"] > row["sel_all_rmse"] > 0
    assert (tmp_path / "smoke").is_dir()


def test_rejects_an_override_without_a_value(selection_module, kitti_root, tmp_path):
    with pytest.raises(SystemExit):
        selection_module.main(["train", "bad", "--kitti-root", str(kitti_root), "--out", str(tmp_path), "max_steps"])
