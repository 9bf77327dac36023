"""Best learned vs strongest classical: the per-drive ratio behind the project's goal."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from inpaintenv.benchmark import headline_markdown, learned_vs_classical, run_benchmark, write_report
from inpaintenv.data import ArrayDataset
from inpaintenv.report.results import EvaluationResult


def _rows(method, drive, holes, alls=None, protocol="rect-v1", seed=0, counts=None):
    alls = alls or [h / 2 for h in holes]
    counts = counts or [100] * len(holes)
    return [
        {"method": method, "protocol": protocol, "drive": drive, "seed": seed, "index": i,
         "hole_rmse": h if c else float("nan"), "all_rmse": a, "hole_count": c}
        for i, (h, a, c) in enumerate(zip(holes, alls, counts))
    ]


def test_picks_the_best_of_each_kind_and_pairs_frames():
    rows = (_rows("harmonic", "d0", [4.0, 6.0, 8.0]) + _rows("scanline", "d0", [5.0, 5.0, 5.0])
            + _rows("constant", "d0", [20.0, 20.0, 20.0])
            + _rows("mine", "d0", [3.0, 3.0, 6.0], alls=[1.0, 2.0, 3.0]) + _rows("other", "d0", [9.0, 9.0, 9.0]))
    (row,) = learned_vs_classical(EvaluationResult(rows=rows, meta={}))
    assert (row["learned"], row["classical"]) == ("mine", "scanline")  # scanline 5.0 < harmonic 6.0
    assert row["hole_ratio"] == pytest.approx(4.0 / 5.0)
    assert row["hole_ratio_low"] <= row["hole_ratio"] <= row["hole_ratio_high"]
    assert row["all_over_classical_hole"] == pytest.approx(2.0 / 5.0)
    assert row["n_frames"] == 3 and (row["protocol"], row["drive"]) == ("rect-v1", "d0")


def test_groups_by_drive_and_skips_frames_without_hole_truth():
    rows = (_rows("harmonic", "d0", [4.0, 4.0]) + _rows("mine", "d0", [2.0, 2.0])
            + _rows("harmonic", "d1", [4.0, 100.0], counts=[100, 0]) + _rows("mine", "d1", [8.0, 100.0], counts=[100, 0]))
    out = learned_vs_classical(EvaluationResult(rows=rows, meta={}))
    by_drive = {r["drive"]: r for r in out}
    assert by_drive["d0"]["hole_ratio"] == pytest.approx(0.5)
    d1 = by_drive["d1"]
    assert (d1["n_frames"], d1["n_skipped_hole"], d1["hole_ratio_n"]) == (2, 1, 1)
    assert d1["hole_ratio"] == pytest.approx(2.0)
    assert math.isnan(d1["hole_ratio_low"]) and math.isnan(d1["hole_ratio_high"])  # one frame: no interval


def test_nothing_to_compare_without_both_kinds():
    only_classical = _rows("harmonic", "d0", [4.0]) + _rows("scanline", "d0", [5.0])
    assert learned_vs_classical(EvaluationResult(rows=only_classical, meta={})) == []
    assert headline_markdown([]) == ""
    with pytest.raises(ValueError, match="confidence"):
        learned_vs_classical(EvaluationResult(rows=only_classical, meta={}), confidence=1.0)


def test_custom_classical_set_and_markdown():
    rows = _rows("a", "d0", [2.0, 4.0]) + _rows("b", "d0", [4.0, 4.0])
    (row,) = learned_vs_classical(EvaluationResult(rows=rows, meta={}), classical={"b"})
    assert row["learned"] == "a" and math.isclose(row["hole_ratio"], 0.75)
    md = headline_markdown([row])
    assert "| rect-v1 | d0 | 2 | 0 | a 3.00 | b 4.00 | 0.75 [" in md


def test_report_and_json_carry_the_headline(small_gt, tmp_path):
    data = ArrayDataset(np.concatenate([small_gt, small_gt + 1.0]), groups=["d0"] * len(small_gt) * 2)

    def ten(x):
        return np.where(np.isnan(x), 10.0, x)

    ten.kind = "classical"  # a user's own classical fill says what it is
    methods = {"ten": ten, "mine": lambda x: np.where(np.isnan(x), np.nanmedian(np.where(x > 0, x, np.nan)), x)}
    res = run_benchmark(methods, data, protocols=["rect-v1"], seeds=[0], out_dir=tmp_path, progress=False)
    assert res.meta["kinds"] == {"ten": "classical", "mine": "submitted"}
    paths = write_report(res, tmp_path / "report")
    doc = json.loads(paths["json"].read_text())
    (head,) = doc["headline"]
    assert head["learned"] == "mine" and head["classical"] == "ten" and head["learned_kind"] == "submitted"
    md = paths["markdown"].read_text()
    assert "## Best submitted vs strongest classical" in md and "best submitted (hole RMSE m)" in md


def test_a_users_own_methods_are_labelled_submitted_not_learned(tmp_path, capsys):
    # The kind comes from what a method is, not from its name.
    from estimators.classical import NearestInpainter

    from inpaintenv.benchmark.suites import LazyMethod, method_kind

    def my_median(x):
        return np.where(np.isnan(x), np.nanmedian(x), x)

    assert method_kind("my_median", my_median) == "submitted"
    assert method_kind("n", NearestInpainter()) == "classical"
    assert method_kind("harmonic", LazyMethod(lambda: None)) == "classical"  # a registered name
    assert method_kind("pretrained", LazyMethod(lambda: None)) == "learned"
    assert method_kind("mine", LazyMethod(lambda: None, identity="checkpoint:abc")) == "learned"
    rows = _rows("harmonic", "d0", [4.0, 4.0]) + _rows("my_median", "d0", [2.0, 2.0])
    result = EvaluationResult(rows=rows, meta={"kinds": {"harmonic": "classical", "my_median": "submitted"}})
    (row,) = learned_vs_classical(result)
    assert row["learned_kind"] == "submitted"
    md = headline_markdown([row])
    assert "best submitted (hole RMSE m)" in md and "best learned" not in md


def test_a_classical_method_at_0_m_makes_the_ratio_undefined_not_a_crash():
    # The strongest classical method is perfect on these frames.
    rows = _rows("harmonic", "d0", [0.0, 0.0]) + _rows("mine", "d0", [2.0, 3.0])
    (row,) = learned_vs_classical(EvaluationResult(rows=rows, meta={}))
    assert math.isnan(row["hole_ratio"]) and math.isnan(row["all_over_classical_hole"])
    assert row["undefined"] == "harmonic scores 0 m in the holes: a ratio to 0 is undefined"
    md = headline_markdown([row])
    assert "| undefined ¶ | undefined ¶ |" in md
    assert "¶ harmonic scores 0 m in the holes: a ratio to 0 is undefined." in md


def test_an_interval_wrapper_is_of_its_bases_kind():
    # pretrained-intervals predicts as pretrained: learned, never "submitted" for living elsewhere.
    from estimators.classical import ScanlineInpainter
    from estimators.intervals import ConformalIntervalInpainter

    from inpaintenv.benchmark.suites import LazyMethod, method_kind, registry_kind

    assert method_kind("pretrained-intervals", LazyMethod(lambda: None, kind=registry_kind("pretrained-intervals"))) \
        == "learned"
    assert registry_kind("pretrained-intervals") == "learned"
    assert method_kind("mine", ConformalIntervalInpainter(ScanlineInpainter())) == "classical"

    def my_median(x):
        return np.where(np.isnan(x), np.nanmedian(x), x)

    assert method_kind("mine", ConformalIntervalInpainter(my_median)) == "submitted"
