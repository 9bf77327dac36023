"""A benchmark run of tasks: protocols on maps and on single LiDAR scans in one run folder."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from inpaintenv.benchmark import headline_markdown, learned_vs_classical, run_benchmark, write_report
from inpaintenv.benchmark.report import table_keys
from inpaintenv.benchmark.suites import CLASSICAL, SCAN_METHODS, SUITES, suite_tasks
from inpaintenv.benchmark.tasks import Task, check_tasks, parse_task
from inpaintenv.data import SyntheticStreets
from inpaintenv.evaluate import evaluate
from inpaintenv.exceptions import InvalidInputError, RunMismatchError
from inpaintenv.metrics import task_of


def mean_fill(x: np.ndarray) -> np.ndarray:
    return np.where(np.isnan(x), np.nanmean(np.where(x > 0, x, np.nan)), x)


def far_fill(x: np.ndarray) -> np.ndarray:
    return np.where(np.isnan(x), 30.0, x)


mean_fill.kind = "classical"  # the headline compares far_fill with it
far_fill.kind = "learned"


@pytest.fixture(scope="module")
def sources():
    kw = dict(n=4, frame_shape=(64, 96), frames_per_drive=2)
    return {"map": SyntheticStreets(**kw), "scan": SyntheticStreets(**kw, input="scan")}


TASKS = ["rect-v1", "scan:densify-v1", Task("scan", "rect-v1", ("mean",))]


def run(sources, out, **kw):
    methods = {"mean": mean_fill, "far": far_fill}
    return run_benchmark(methods, sources, protocols=TASKS, out_dir=out, progress=False, **kw)


def test_parse_task():
    assert parse_task("rect-v1") == Task("map", "rect-v1")
    assert parse_task("scan:rect-v1") == Task("scan", "rect-v1")
    assert parse_task("rect-v1", "scan").label == "scan:rect-v1"
    with pytest.raises(InvalidInputError, match="densify-v1.*scan"):
        parse_task("densify-v1")
    with pytest.raises(InvalidInputError, match="distinct"):
        check_tasks(["scan:rect-v1", Task("scan", "rect-v1")])


def test_one_run_scores_maps_and_scans_like_evaluate(sources, tmp_path):
    res = run(sources, tmp_path)
    got = {(r["method"], r["input_kind"], r["protocol"]) for r in res.rows}
    # The restricted scan task scores only the method it lists.
    assert got == {("mean", "map", "rect-v1"), ("far", "map", "rect-v1"), ("mean", "scan", "densify-v1"),
                   ("far", "scan", "densify-v1"), ("mean", "scan", "rect-v1")}
    files = sorted(p.name for p in (tmp_path / "rows").iterdir())
    assert "mean__rect-v1.jsonl" in files and "mean__rect-v1__scan.jsonl" in files
    for kind, protocol in (("scan", "densify-v1"), ("scan", "rect-v1"), ("map", "rect-v1")):
        alone = evaluate(mean_fill, sources[kind], protocol, name="mean", progress=False)
        ours = [r for r in res.rows if (r["method"], r["input_kind"], r["protocol"]) == ("mean", kind, protocol)]
        for a, b in zip(sorted(alone.rows, key=lambda r: r["index"]), sorted(ours, key=lambda r: r["index"])):
            for col in ("hole_rmse", "unmeasured_rmse", "all_rmse", "kitti_rmse"):
                assert a[col] == pytest.approx(b[col], nan_ok=True)
    assert res.meta["tasks"] == ["rect-v1", "scan:densify-v1", "scan:rect-v1"]


def test_resume_reuses_rows_and_a_map_run_keeps_its_key(sources, tmp_path):
    first = run(sources, tmp_path)
    stamp = {p.name: p.stat().st_mtime_ns for p in (tmp_path / "rows").iterdir()}
    again = run(sources, tmp_path)
    assert {p.name: p.stat().st_mtime_ns for p in (tmp_path / "rows").iterdir()} == stamp
    assert len(again.rows) == len(first.rows)
    state = json.loads((tmp_path / "run.json").read_text())
    assert state["scan"]["protocols"] == ["densify-v1", "rect-v1"]
    with pytest.raises(RunMismatchError, match="scan tasks"):
        run_benchmark({"mean": mean_fill}, sources, protocols=["rect-v1", "scan:rect-v1"], out_dir=tmp_path,
                      progress=False)
    # A run on maps alone is keyed as it always was: no scan entry.
    run_benchmark({"mean": mean_fill}, sources["map"], protocols=["rect-v1"], out_dir=tmp_path / "m", progress=False)
    assert "scan" not in json.loads((tmp_path / "m" / "run.json").read_text())


def test_a_scan_task_needs_a_scan_source(sources, tmp_path):
    with pytest.raises(InvalidInputError, match="input kind 'scan'"):
        run_benchmark({"mean": mean_fill}, sources["map"], protocols=["scan:rect-v1"], out_dir=tmp_path,
                      progress=False)
    # A source of scans makes plain protocol names scan tasks.
    res = run_benchmark({"mean": mean_fill}, sources["scan"], protocols="densify-v1", out_dir=tmp_path / "s",
                        progress=False)
    assert {r["input_kind"] for r in res.rows} == {"scan"}


def test_headline_scores_densify_on_unmeasured_pixels(sources, tmp_path):
    res = run(sources, tmp_path)
    heads = learned_vs_classical(res, keys=("input_kind", "protocol"))
    by_task = {(h["input_kind"], h["protocol"]): h for h in heads}
    dense = by_task[("scan", "densify-v1")]
    assert dense["task"] == "unmeasured"
    rows = [r for r in res.rows if r["protocol"] == "densify-v1" and r["method"] == "mean"]
    assert task_of(r["hole_fraction"] for r in rows) == "unmeasured"
    assert dense["classical_hole_rmse"] == pytest.approx(np.mean([r["unmeasured_rmse"] for r in rows]))
    assert not math.isnan(dense["hole_ratio"])
    assert by_task[("map", "rect-v1")]["task"] == "hole"
    assert ("scan", "rect-v1") not in by_task  # far is not scored there: nothing to compare
    text = headline_markdown(learned_vs_classical(res))
    assert "| scan | densify-v1 |" in text and "unmeasured pixels" in text


def test_report_tables_name_the_input_kind(sources, tmp_path):
    res = run(sources, tmp_path)
    assert table_keys(res) == ("method", "input_kind", "protocol")
    paths = write_report(res, tmp_path)
    md = paths["markdown"].read_text()
    assert "| mean | scan | densify-v1 |" in md and "unmeasured RMSE (m)" in md and "KITTI RMSE (mm)" in md
    doc = json.loads(paths["json"].read_text())
    dense = next(e for e in doc["table"] if e["protocol"] == "densify-v1" and e["method"] == "mean")
    assert dense["unmeasured_rmse"] is not None and dense["hole_rmse"] is None


def test_default_suite_scores_densify_and_rect_on_scans():
    tasks = {t.label: t for t in suite_tasks("default", SUITES["default"])}
    assert {"rect-v1", "scan:densify-v1", "scan:rect-v1"} <= set(tasks)
    assert tasks["rect-v1"].methods is None
    assert "ipbasic-scan" in CLASSICAL and "ipbasic-scan" in tasks["scan:densify-v1"].methods
    assert set(tasks["scan:densify-v1"].methods) == set(SCAN_METHODS) & set(SUITES["default"])
    assert all(t.input_kind == "map" for t in suite_tasks("study", SUITES["study"]))


def test_command_scores_the_suite_tasks_and_input_scan(tmp_path, capsys, monkeypatch):
    from inpaintenv.cli import main

    monkeypatch.delenv("INPAINTENV_KITTI_ROOT", raising=False)
    common = ["--n-frames", "16", "--frame-shape", "48", "96", "--holdout", "0.5", "--quiet", "--figure-frames", "1"]
    out = tmp_path / "scan"
    assert main(["benchmark", "-m", "harmonic", "-m", "nearest", "--input", "scan", "-p", "densify-v1",
                 "--out", str(out), *common]) == 0
    table = capsys.readouterr().out
    assert "| harmonic | scan | densify-v1 |" in table and "unmeasured RMSE (m)" in table
    doc = json.loads((out / "results.json").read_text())
    assert {r["input_kind"] for r in doc["rows"]} == {"scan"}
    assert (out / "figures" / "error_vs_nearest.png").is_file()  # a scan-only run has its figures too
    assert "scan:densify-v1" in (out / "report.html").read_text()
    # A suite without --protocol/--input scores its tasks; a method added to it is scored on scans too.
    out = tmp_path / "suite"
    monkeypatch.setitem(SUITES, "default", ["harmonic", "ipbasic-scan"])
    assert main(["benchmark", "-m", "nearest", "--suite", "default", "--out", str(out), *common]) == 0
    rows = json.loads((out / "results.json").read_text())["rows"]
    assert {(r["input_kind"], r["protocol"]) for r in rows if r["method"] == "nearest"} == {
        ("map", "rect-v1"), ("scan", "densify-v1"), ("scan", "rect-v1")}
    assert "Best" not in capsys.readouterr().out  # no learned method: no headline
    assert main(["benchmark", "-m", "harmonic", "-p", "densify-v1", "--out", str(tmp_path / "x"), *common]) == 1
    assert "--input scan" in capsys.readouterr().err


def test_every_method_is_compared_with_the_strongest_classical(sources, tmp_path):
    from inpaintenv.benchmark.headline import every_method_markdown, every_method_vs_strongest

    res = run(sources, tmp_path)
    entries = every_method_vs_strongest(res)
    dense = {e["method"]: e for e in entries if e["protocol"] == "densify-v1"}
    assert dense["mean"]["ratio"] == pytest.approx(1.0) and dense["mean"]["classical"] == "mean"
    rows = {m: [r["unmeasured_rmse"] for r in res.rows if r["protocol"] == "densify-v1" and r["method"] == m]
            for m in ("far", "mean")}
    assert dense["far"]["ratio"] == pytest.approx(np.mean(rows["far"]) / np.mean(rows["mean"]))
    assert dense["far"]["ratio_low"] <= dense["far"]["ratio"] <= dense["far"]["ratio_high"]
    assert "| scan | densify-v1 | far |" in every_method_markdown(entries)
    assert "Every method vs the strongest classical" in write_report(res, tmp_path)["markdown"].read_text()
