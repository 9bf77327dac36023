"""perf/bench_blend.py times the shipped blend beside harmonic on the same frames."""

from __future__ import annotations

import pytest

pytest.importorskip("torch")


def test_times_blend_features_and_harmonic(load_benchmark, capsys):
    out = load_benchmark("bench_blend").main(["--frames", "1", "--repeat", "1"])
    assert out["frame"] == [352, 1216] and out["frames"] == 1 and out["predict_threads"] == 1
    assert out["median_blend_ms"] > 0 and out["median_harmonic_ms"] > 0 and out["median_features_ms"] > 0
    assert out["blend_over_harmonic"] == round(out["median_blend_ms"] / out["median_harmonic_ms"], 2)
    assert 0 < out["median_pixels_to_fill"] < 352 * 1216
    assert '"median_blend_ms"' in capsys.readouterr().out
    with pytest.raises(SystemExit):
        load_benchmark("bench_blend").main(["--threads", "0"])
