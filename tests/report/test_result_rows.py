"""What a result row may be (inpaintenv.values.rows), as results.json and results.csv are read back."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hostile_rows import HOSTILE_ROWS

from inpaintenv.evaluate import evaluate
from inpaintenv.exceptions import InpaintenvError, ResultRowError
from inpaintenv.metrics import INTERVAL_COLUMNS, frame_metrics, metric_record, metric_records
from inpaintenv.report.results import METRIC_COLUMNS, ROW_COLUMNS, EvaluationResult, parse_row
from inpaintenv.values.rows import check_row, row_column_kind

#: Edits that need the run's plan to be refused (a results file has no plan): checked on resume only.
NEEDS_PLAN = {"duplicate-other-protocol", "made-up-drive", "made-up-frame", "unplanned-index", "unplanned-seed",
              "other-method", "other-input", "unknown-input"}


@pytest.fixture(scope="module")
def result(tmp_path_factory):
    from estimators.classical import HarmonicInpainter

    res = evaluate(HarmonicInpainter(), None, n_frames=3, progress=False)  # the built-in synthetic streets
    folder = tmp_path_factory.mktemp("res")
    res.to_json(folder / "results.json")
    res.to_csv(folder / "results.csv")
    return folder


def test_every_column_evaluate_writes_is_one_a_row_may_have():
    assert all(row_column_kind(c) is not None for c in (*ROW_COLUMNS, *INTERVAL_COLUMNS))
    assert {r.name for r in metric_records()} >= set(INTERVAL_COLUMNS) | {c for c in METRIC_COLUMNS
                                                                          if not c.endswith("_count")}
    assert row_column_kind("score_bonus") is None


def test_the_records_ranges_hold_what_scoring_gives_at_its_extremes():
    gt = np.full((1, 8, 8), 255.99609375, np.float32)
    hole = np.zeros((1, 8, 8), bool)
    hole[0, :2] = True
    for pred in (np.zeros_like(gt) + 1e-3, gt.copy()):  # the largest error there is, and none
        metrics = frame_metrics(pred, gt, hole, unfilled="zero")
        for column, values in metrics.items():
            if not column.endswith("_count"):
                low, high = metric_record(column).bounds
                assert low - 1e-6 <= float(values[0]) <= high + 1e-6, column


def test_a_registered_metric_is_a_column_a_row_may_have_within_its_range(result):
    from inpaintenv.metrics import Metric, register_metric
    from inpaintenv.metrics._records import _RECORDS

    row = json.loads((result / "results.json").read_text())["rows"][0]
    register_metric(Metric("hole_share_far", "share of hole pixels beyond 40 m", "mean", False, "share", "far",
                           ".2f", 0.0, 1.0, "task"))
    try:
        assert check_row({**row, "hole_share_far": 0.25})["hole_share_far"] == 0.25
        with pytest.raises(ResultRowError, match=r"hole_share_far is 1\.5, outside what it can be \(0 to 1\)"):
            check_row({**row, "hole_share_far": 1.5})
    finally:
        del _RECORDS["hole_share_far"]
    with pytest.raises(ResultRowError, match="unknown column 'hole_share_far'"):
        check_row({**row, "hole_share_far": 0.25})


def test_a_written_result_reads_back_the_same(result):
    for path, read in ((result / "results.json", EvaluationResult.from_json),
                       (result / "results.csv", EvaluationResult.from_csv)):
        rows = read(path).rows
        assert len(rows) == 3 and all(isinstance(r["seed"], int) and isinstance(r["hole_count"], int) for r in rows)


def _edit_results(name: str, result, tmp_path) -> str:
    """``result``'s results.json with hostile edit ``name`` applied, written to ``tmp_path``; what the refusal says."""
    edit, says = HOSTILE_ROWS[name]
    doc = json.loads((result / "results.json").read_text())
    doc["rows"] = edit(doc["rows"])
    (tmp_path / "results.json").write_text(json.dumps(doc))
    return says


@pytest.mark.parametrize("name", sorted(set(HOSTILE_ROWS) - NEEDS_PLAN))
def test_a_hand_edited_results_json_is_refused_naming_the_row(name, result, tmp_path):
    says = _edit_results(name, result, tmp_path)
    with pytest.raises(InpaintenvError, match=rf"results\.json|{says}"):
        EvaluationResult.from_json(tmp_path / "results.json")


@pytest.mark.parametrize("name", ["negative-rmse", "seed-true", "psnr-not-its-rmse", "duplicate-identical"])
def test_the_refusal_names_the_row_and_the_column(name, result, tmp_path):
    says = _edit_results(name, result, tmp_path)
    with pytest.raises(ResultRowError, match=rf"row \d of .*results\.json is not a possible result row: .*{says}"):
        EvaluationResult.from_json(tmp_path / "results.json")


def test_a_hand_edited_results_csv_is_refused(result, tmp_path):
    text = (result / "results.csv").read_text().splitlines()
    header = text[0].split(",")
    cells = text[1].split(",")
    cells[header.index("hole_rmse")] = "-5"
    (tmp_path / "results.csv").write_text("\n".join([text[0], ",".join(cells), *text[2:]]) + "\n")
    with pytest.raises(ResultRowError, match=r"row 1 of .*results\.csv .*hole_rmse is -5\.0"):
        EvaluationResult.from_csv(tmp_path / "results.csv")


def test_a_results_json_whose_meta_is_not_an_object_is_one_error(result, tmp_path):
    doc = json.loads((result / "results.json").read_text())
    (tmp_path / "results.json").write_text(json.dumps({**doc, "meta": [1, 2]}))
    with pytest.raises(InpaintenvError, match="meta is an object"):
        EvaluationResult.from_json(tmp_path / "results.json")
    (tmp_path / "results.json").write_text(json.dumps({**doc, "meta": {**doc["meta"], "max_depth": -1}}))
    with pytest.raises(InpaintenvError, match="max_depth"):
        EvaluationResult.from_json(tmp_path / "results.json")


def test_a_frame_whose_hole_holds_no_truth_is_a_possible_row(result):
    row = json.loads((result / "results.json").read_text())["rows"][0]
    empty = {c: None for c in row if c.split("_")[0] in ("hole", "unmeasured") and c != "hole_fraction"}
    parsed = parse_row({**row, **empty, "hole_count": 0, "unmeasured_count": 0})
    assert math.isnan(parsed["hole_rmse"]) and parsed["hole_count"] == 0
    with pytest.raises(ResultRowError, match="no scored pixel"):
        check_row({**row, "hole_count": 0, "unmeasured_count": 0})  # a count of 0 with a value: not a frame's


def test_rows_of_older_runs_without_the_newer_columns_still_read():
    legacy = {c: v for c, v in json.loads(json.dumps(_one_row())).items()
              if not c.startswith(("unmeasured_", "kitti_")) and c != "input_kind"}
    assert "input_kind" not in parse_row(legacy)
    with pytest.raises(ResultRowError, match="missing columns? 'kitti_"):
        parse_row({**legacy, "kitti_rmse": 1000 * legacy["all_rmse"]})  # a group is all there or all absent


def _one_row():
    from estimators.classical import HarmonicInpainter

    return evaluate(HarmonicInpainter(), None, n_frames=1, progress=False).rows[0]
