"""perf/bench_sparse_residual.py times SparseResidualInpainter beside harmonic on thinned scans."""

from __future__ import annotations

import pytest

pytest.importorskip("torch")


def test_times_predict_features_and_harmonic_per_density(load_benchmark, capsys):
    out = load_benchmark("bench_sparse_residual").main(["--frames", "1", "--repeat", "1"])
    assert out["frames"] == "synthetic" and out["predict_threads"] == 1 and len(out["load_average"]) == 2
    assert set(out["densities"]) == {"16 beams", "8 beams"}
    for row in out["densities"].values():
        assert row["frames"] == 1 and row["frame"] == [352, 1216]
        assert row["median_predict_ms"] > 0 and row["median_harmonic_ms"] > 0 and row["median_features_ms"] > 0
        assert row["predict_over_harmonic"] > 0 and row["cpu_predict_over_harmonic"] > 0 and row["median_cpu_predict_ms"] > 0
    assert '"predict_over_harmonic"' in capsys.readouterr().out
    with pytest.raises(SystemExit):
        load_benchmark("bench_sparse_residual").main(["--threads", "0"])
