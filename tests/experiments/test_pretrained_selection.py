"""experiments/pretrained_selection.py end to end with the seconds-long smoke preset."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

_DIR = Path(__file__).resolve().parents[2] / "experiments"


@pytest.fixture(scope="module")
def selection_module():
    sys.path.insert(0, str(_DIR))
    try:
        import pretrained_selection

        yield pretrained_selection
    finally:
        sys.path.remove(str(_DIR))


def test_trains_on_real_plus_synthetic_frames_and_scores_sel(selection_module, kitti_root, tmp_path):
    row = selection_module.main(["smoke", "--preset", "smoke", "--kitti-root", str(kitti_root),
                                 "--out", str(tmp_path), "--synthetic", "2", "max_steps=1"])
    assert row["synthetic"] == 2 and row["overrides"] == {"max_steps": "1"}
    assert row["sel_hole_rmse"] > row["sel_all_rmse"] > 0
    assert (tmp_path / "smoke").is_dir()


def test_rejects_an_override_without_a_value(selection_module, kitti_root, tmp_path):
    with pytest.raises(SystemExit):
        selection_module.main(["bad", "--kitti-root", str(kitti_root), "--out", str(tmp_path), "max_steps"])
