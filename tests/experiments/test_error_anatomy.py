"""experiments/error_anatomy.py on the real selection frames (a cheap method only)."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import pytest

_DIR = Path(__file__).resolve().parents[2] / "experiments"


@pytest.fixture(scope="module")
def anatomy_module():
    sys.path.insert(0, str(_DIR))  # the script imports its siblings
    try:
        import error_anatomy

        yield error_anatomy
    finally:
        sys.path.remove(str(_DIR))


def test_breaks_down_the_hole_error_by_true_depth(anatomy_module, kitti_root, capsys):
    (row,) = anatomy_module.main(["--kitti-root", str(kitti_root), "-m", "scanline"])
    bins = row["bins"]
    assert math.isclose(sum(b["pixel_share"] for b in bins), 1.0)
    assert math.isclose(sum(b["sse_share"] for b in bins), 1.0)
    # The bins recompose the pooled hole RMSE.
    recomposed = math.sqrt(sum(b["pixel_share"] * b["rmse"] ** 2 for b in bins if b["pixels"]))
    assert math.isclose(recomposed, row["pooled_hole_rmse"], rel_tol=1e-9)
    # The point of the script: on real frames, far pixels carry more than their share of the error.
    far = [b for b in bins if b["lo"] >= 30]
    assert sum(b["sse_share"] for b in far) > sum(b["pixel_share"] for b in far)
    assert 0 < row["gross_pixel_share"] < row["gross_sse_share"] <= 1
    assert "| true depth (m) |" in capsys.readouterr().out


def test_any_drives_under_several_seeds(anatomy_module, tiny_kitti):
    argv = ["--kitti-root", str(tiny_kitti), "--drive", "2011_09_26_drive_9001_sync", "-m", "scanline"]
    (one,) = anatomy_module.main(argv)
    (two,) = anatomy_module.main([*argv, "--seed", "0", "--seed", "1"])
    assert math.isclose(sum(b["pixel_share"] for b in two["bins"]), 1.0)
    # seed 0's frame-mask is the whole of the one-seed run, so the two-seed run holds more pixels
    assert sum(b["pixels"] for b in two["bins"]) > sum(b["pixels"] for b in one["bins"])
