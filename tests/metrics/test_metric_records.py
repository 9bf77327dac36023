"""One record per metric: a record registered once appears in evaluate, the tables, the pooled
aggregate and score, with no other edit."""

from __future__ import annotations

import numpy as np
import pytest

from inpaintenv import metrics
from inpaintenv.data import SyntheticStreets, write_depth_png
from inpaintenv.evaluate import evaluate
from inpaintenv.exceptions import InpaintenvError
from inpaintenv.masks import get_protocol
from inpaintenv.metrics import Metric, aggregate, metric_record, register_metric
from inpaintenv.metrics import _records
from inpaintenv.report.tables import summary_table, to_markdown


def _max_error(batch) -> np.ndarray:
    """The largest absolute error over each frame's scored pixels (a test metric)."""
    valid = batch.scored & (batch.gt > 0)
    err = np.where(valid, np.abs(batch.pred - batch.gt), -np.inf)
    return np.where(valid.any(axis=(1, 2)), err.max(axis=(1, 2)), np.nan)


@pytest.fixture
def max_error(monkeypatch):
    """A new metric record, registered for the test only (pooled as a mean over pixels)."""
    monkeypatch.setattr(_records, "_RECORDS", dict(_records._RECORDS))
    return register_metric(Metric("hole_max_error", "largest absolute error over the hole", "mean", False, "m",
                                  "hole max error (m)", ".3f", 0.0, np.inf, "task", "task", "depth",
                                  compute=_max_error))


def fill_ten(x):
    return np.where(np.isnan(x), 10.0, x).astype(np.float32)


def test_a_new_record_appears_in_evaluate_the_tables_the_pooled_aggregate_and_score(max_error, tmp_path):
    streets = SyntheticStreets(n=4, seed=0, frame_shape=(64, 192))
    result = evaluate(fill_ten, streets, "rect-v1", seeds=[0], progress=False)
    for row, k in zip(result.rows, range(4)):  # per frame: the record's own computation
        gt = streets[k]
        hole = get_protocol("rect-v1").mask(gt.shape, 0, k)
        valid = hole & (gt > 0)
        assert row["hole_max_error"] == pytest.approx(np.abs(10.0 - gt[valid]).max())
    table = summary_table(result)
    assert table[0]["hole_max_error"] == pytest.approx(np.mean([r["hole_max_error"] for r in result.rows]))
    assert "hole max error (m)" in to_markdown(table) and "hole_max_error_low" in table[0]
    pooled = aggregate(result.rows, how="pooled")
    weights = np.array([r["hole_count"] for r in result.rows], float)
    assert pooled["hole_max_error"] == pytest.approx(
        np.dot([r["hole_max_error"] for r in result.rows], weights) / weights.sum())
    assert "hole_max_error" in result.to_csv(tmp_path / "rows.csv").read_text().splitlines()[0]

    from inpaintenv.submission import export, score

    manifest = export(tmp_path / "inputs", streets, "rect-v1", [0], n_frames=4, progress=False, trusted=True)
    for item in manifest.items:
        depth, hole = manifest.read_input(item), manifest.read_hole(item)
        write_depth_png(tmp_path / "predictions" / item.input, np.where(hole, 10.0, depth))
    scored = score(manifest, tmp_path / "predictions", name="ten")
    assert [r["hole_max_error"] for r in scored.rows] == pytest.approx([r["hole_max_error"] for r in result.rows])


def test_the_benchmark_table_shows_a_new_record(max_error, tmp_path):
    from inpaintenv.benchmark import run_benchmark, write_report

    res = run_benchmark({"ten": fill_ten}, SyntheticStreets(n=3, seed=1, frame_shape=(64, 192)), out_dir=tmp_path,
                        progress=False)
    assert all(np.isfinite(r["hole_max_error"]) for r in res.rows)
    assert "hole max error (m)" in write_report(res, tmp_path)["markdown"].read_text()


def test_every_metric_column_has_one_record_and_a_pooling_rule():
    from inpaintenv.report.results import METRIC_COLUMNS

    for column in [*METRIC_COLUMNS, *metrics.INTERVAL_COLUMNS]:
        if column.endswith("_count"):
            continue
        record = metric_record(column)
        assert record.pool in metrics.POOLS and record.low <= record.high and record.label
    with pytest.raises(InpaintenvError, match="pool must be one of"):
        Metric("x", "", "median", False, "m", "x", ".2f")
    with pytest.raises(InpaintenvError, match="no metric 'nope'"):
        metric_record("nope")
