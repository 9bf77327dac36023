"""perf/bench_env.py: measures the plain loop, the env and vector envs; falls back to synthetic frames."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

_DIR = Path(__file__).resolve().parents[2] / "perf"


@pytest.fixture(scope="module")
def bench_env():
    sys.path.insert(0, str(_DIR))
    try:
        import bench_env
    finally:
        sys.path.remove(str(_DIR))
    return bench_env


def test_reports_every_measurement_and_says_when_frames_are_synthetic(bench_env, capsys, tmp_path):
    args = ["--kitti-root", str(tmp_path), "--shape", "24", "40", "--frames", "3", "--episodes", "4", "--repeats", "1"]
    out = bench_env.main(args)
    assert out["source"].startswith("3 synthetic frames") and "no KITTI train split" in out["source"]
    assert set(out["frames_per_s"]) == {
        "plain NumPy loop (reference)", "env reset+step (in memory)",
        "vector env, sync, 2 envs (in memory)", "vector env, async, 2 envs (in memory)",
        "frame_metrics, batch of 8", "evaluate() overhead (batch 8)",
    }
    assert all(rate > 0 for rate in out["frames_per_s"].values())
    printed = capsys.readouterr().out
    assert "real KITTI frames were not used" in printed and "| env reset+step (in memory) |" in printed
    with pytest.raises(SystemExit):
        bench_env.main(["--episodes", "0"])
