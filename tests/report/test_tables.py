"""One table format for ``evaluate`` and the benchmark, and the interval rule."""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest

from inpaintenv.benchmark import (
    headline_markdown,
    learned_vs_classical,
    summary_table,
    to_markdown,
    write_report,
)
from inpaintenv.data import ArrayDataset
from inpaintenv.evaluate import evaluate
from inpaintenv.report.results import EvaluationResult
from inpaintenv.report.tables import FEW_MARK, interval_cell


def _run(n_frames: int, drives: list[str], offset: float = 0.0) -> EvaluationResult:
    """Two methods (one classical by name, one learned) on frames of varied depth."""
    rng = np.random.default_rng(0)
    frames = rng.uniform(5.0, 30.0, (n_frames, 32, 48)).astype(np.float32)
    data = ArrayDataset(frames, groups=drives)
    results = [
        evaluate(lambda x, v=v: np.nan_to_num(x, nan=v), data, progress=False, name=name)
        for name, v in (("harmonic", 12.0 + offset), ("mine", 15.0))
    ]
    return EvaluationResult.concat(results)


def test_one_frame_has_no_interval_in_markdown_json_and_csv(tmp_path):
    # Drive d1 has a single frame: its interval does not exist (was "x ± 0.00").
    res = _run(13, ["d0"] * 12 + ["d1"])
    md = res.to_markdown(res.by_drive())
    d1 = [line for line in md.splitlines() if "| d1 |" in line]
    assert len(d1) == 2 and all("(n=1)" in line and "±" not in line for line in d1)
    assert "(n=1): one frame, so no interval." in md
    paths = write_report(res, tmp_path)
    doc = json.loads(paths["json"].read_text())
    entry = next(e for e in doc["by_drive"] if e["drive"] == "d1" and e["method"] == "mine")
    assert entry["hole_rmse_low"] is None and entry["hole_rmse_high"] is None
    assert entry["hole_rmse_n"] == 1 and entry["hole_rmse"] is not None
    with paths["by_drive_csv"].open() as f:
        row = next(r for r in csv.DictReader(f) if r["drive"] == "d1" and r["method"] == "mine")
    assert row["hole_rmse_low"] == row["hole_rmse_high"] == "" and row["hole_rmse_n"] == "1"
    # The headline's ratio from one frame: no interval either.
    (head,) = [h for h in learned_vs_classical(res) if h["drive"] == "d1"]
    assert math.isnan(head["hole_ratio_low"]) and math.isnan(head["hole_ratio_high"]) and head["hole_ratio_n"] == 1
    line = next(x for x in headline_markdown([head]).splitlines() if "| d1 |" in x)
    assert "(n=1)" in line and "[" not in line.split("|")[-3]


def test_intervals_from_few_frames_are_marked_and_explained():
    res = _run(5, ["d0"] * 5)
    md = res.to_markdown()
    row = next(line for line in md.splitlines() if "| mine |" in line)
    assert row.count(FEW_MARK) == 6 and "±" in row
    assert f"{FEW_MARK} interval from fewer than 10 frames" in md
    many = _run(12, ["d0"] * 12).to_markdown()
    assert FEW_MARK not in many  # 12 frames: an ordinary interval, no mark, no note


def test_interval_cell_rule():
    assert interval_cell(15.3, float("nan"), float("nan"), 1, ".2f") == "15.30 (n=1)"
    assert interval_cell(1.31, None, None, 1, ".2f", brackets=True) == "1.31 (n=1)"
    assert interval_cell(2.0, 1.5, 2.25, 4, ".2f") == f"2.00 ± 0.50{FEW_MARK}"
    assert interval_cell(2.0, 1.5, 2.25, 40, ".2f", brackets=True) == "2.00 [1.50, 2.25]"
    assert interval_cell(float("nan"), None, None, 0, ".2f") == "–"


def test_evaluate_and_benchmark_print_the_same_table(tmp_path):
    res = _run(13, ["d0"] * 12 + ["d1"])
    # One function makes both tables: units in the header, intervals, frames and skipped.
    assert res.to_markdown() == to_markdown(summary_table(res))
    header = res.to_markdown().splitlines()[0]
    for col in ("| frames | skipped |", "hole RMSE (m)", "hole PSNR (dB)", "hole iRMSE (1/km)"):
        assert col in header
    assert "| mine | rect-v1 | 13 |" in res.to_markdown()
    assert res.to_markdown(keys=("method", "protocol", "drive")) == to_markdown(
        summary_table(res, ("method", "protocol", "drive")), ("method", "protocol", "drive")
    )


def test_frames_and_skipped_agree_between_table_and_headline():
    rng = np.random.default_rng(1)
    frames = rng.uniform(5.0, 30.0, (12, 32, 48)).astype(np.float32)
    frames[3] = 0.0  # no ground truth anywhere: its hole holds none, so it is skipped
    data = ArrayDataset(frames, groups=["d0"] * 12)
    res = EvaluationResult.concat([
        evaluate(lambda x, v=v: np.nan_to_num(x, nan=v), data, progress=False, name=name)
        for name, v in (("harmonic", 12.0), ("mine", 15.0))
    ])
    assert "| mine | rect-v1 | 12 | 1 |" in res.to_markdown()
    (head,) = learned_vs_classical(res)
    assert (head["n_frames"], head["n_skipped_hole"], head["hole_ratio_n"]) == (12, 1, 11)
    assert "| rect-v1 | d0 | 12 | 1 |" in headline_markdown([head])


@pytest.mark.parametrize("keys", [("method", "protocol"), ("method", "protocol", "drive")])
def test_evaluate_json_table_carries_intervals(tmp_path, keys):
    res = _run(12, ["d0"] * 12)
    doc = json.loads(res.to_json(tmp_path / "r.json").read_text())
    entry = doc["table" if len(keys) == 2 else "by_drive"][0]
    assert entry["hole_rmse_low"] <= entry["hole_rmse"] <= entry["hole_rmse_high"]
    assert entry["hole_rmse_n"] == 12 and entry["n_frames"] == 12
