"""perf/bench_pretrained.py: times the shipped model and restores the chunk size."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

pytest.importorskip("torch")
_DIR = Path(__file__).resolve().parents[2] / "perf"


def test_times_predict_per_chunk_size_and_restores_the_default(capsys):
    sys.path.insert(0, str(_DIR))
    try:
        import bench_pretrained
    finally:
        sys.path.remove(str(_DIR))
    import estimators.learned.nets.pixel_blend as pixel_blend

    default = pixel_blend.CHUNK
    out = bench_pretrained.main(["--repeat", "1", "--threads", "1", "--chunk", "4096", "--chunk", "65536"])
    assert set(out["predict_ms"]) == {4096, 65536}
    assert all(ms > 0 for ms in out["predict_ms"].values()) and out["features_ms"] > 0
    assert out["frame"] == [352, 1216] and 0 < out["unmeasured_pixels"] < 352 * 1216
    assert pixel_blend.CHUNK == default
    assert '"predict_ms"' in capsys.readouterr().out
    with pytest.raises(SystemExit):
        bench_pretrained.main(["--repeat", "0"])
