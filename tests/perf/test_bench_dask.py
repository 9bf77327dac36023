"""The full-release cost arithmetic of perf/bench_dask.py (the measurement itself is
a benchmark, not a test; tests/test_cluster.py covers the distributed path)."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="module")
def bench(load_benchmark):
    return load_benchmark("bench_dask")


def test_release_cost_multiplies_frames_protocols_seeds_and_methods(bench):
    est = bench.release_cost({"a": 1.0, "b": 2.0}, frames=1200, protocols=2, seeds=3, workers=4, efficiency=0.5)
    assert est["core_hours"] == pytest.approx(1200 * 2 * 3 * 3.0 / 3600)  # 6 h of one core
    assert est["wall_hours"] == pytest.approx(6.0 / (4 * 0.5))
