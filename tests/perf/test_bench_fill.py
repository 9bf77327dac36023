"""perf/bench_fill.py times `fill` on a folder of PNGs against the predict loop on the same frames."""

from __future__ import annotations


def test_times_fill_and_the_predict_loop(load_benchmark, tmp_path, capsys):
    out = load_benchmark("bench_fill").main(["--frames", "3", "--method", "scanline", "--json",
                                             str(tmp_path / "fill.json")])
    assert out["frame"] == [352, 1216] and len(out["rows"]) == 1
    row = out["rows"][0]
    assert row["method"] == "scanline" and row["frames"] == 3 and row["predict_s"] > 0 and row["fill_s"] > 0
    assert (tmp_path / "fill.json").is_file() and "overhead" in capsys.readouterr().out
