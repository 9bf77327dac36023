"""A benchmark over LiDAR densities: every --protocol on every --input, a table and a figure by density."""

from __future__ import annotations

import json

import pytest

from inpaintenv.benchmark.density import density_markdown, density_table, has_beams_axis
from inpaintenv.cli import main
from inpaintenv.report.results import EvaluationResult

KINDS = ("scan", "scan-rings16-v1", "scan-rings8-v1", "scan-points25-v1")


def argv_of(out):
    return ["benchmark", "-p", "densify-v1", "-p", "rect-v1", *(a for k in KINDS for a in ("--input", k)),
            "-m", "nearest", "-m", "harmonic", "--n-frames", "4", "--frame-shape", "64", "192", "--holdout", "0",
            "--out", str(out), "-q"]


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("density") / "run"
    assert main(argv_of(out)) == 0
    return out


def test_every_protocol_is_scored_on_every_input(run):
    rows = json.loads((run / "results.json").read_text())["rows"]
    assert {(r["input_kind"], r["protocol"]) for r in rows} == {(k, p) for k in KINDS for p in ("densify-v1", "rect-v1")}
    assert (run / "rows" / "nearest__rect-v1__scan-rings16-v1.jsonl").is_file()


def test_the_report_has_the_density_table_and_figure(run):
    doc = json.loads((run / "results.json").read_text())
    by = {(e["method"], e["protocol"], e["input_kind"]): e for e in doc["by_density"]}
    assert len(by) == 2 * 2 * len(KINDS)
    assert by[("nearest", "densify-v1", "scan-rings8-v1")]["beams"] == 8
    assert by[("nearest", "densify-v1", "scan")]["metric"] == "unmeasured_rmse"
    assert by[("nearest", "rect-v1", "scan")]["metric"] == "hole_rmse"
    # Fewer rings leave the unmeasured pixels farther from a measurement: nearest's error grows.
    assert by[("nearest", "densify-v1", "scan")]["rmse"] < by[("nearest", "densify-v1", "scan-rings16-v1")]["rmse"] \
        < by[("nearest", "densify-v1", "scan-rings8-v1")]["rmse"]
    md = (run / "results.md").read_text()
    assert "## By LiDAR density" in md and "| 16 beams (scan-rings16-v1) |" in md
    assert (run / "figures" / "density" / "error_vs_beams.png").stat().st_size > 0
    html = (run / "report.html").read_text()
    assert "Error by LiDAR density" in html and "Holes in single scans (16 beams)" in html


def test_the_same_command_resumes_the_run_of_every_density(run, capsys):
    before = {p.name: p.read_text() for p in (run / "rows").glob("*.jsonl")}
    assert main(argv_of(run)) == 0  # the run's key holds every input kind: the same run, nothing rescored
    assert {p.name: p.read_text() for p in (run / "rows").glob("*.jsonl")} == before


def test_a_run_on_one_density_has_no_density_axis():
    rows = [{"method": "m", "protocol": "rect-v1", "input_kind": "scan", "seed": 0, "index": 0, "hole_rmse": 1.0}]
    result = EvaluationResult(rows=rows, meta={})
    assert density_table(result) == [] and not has_beams_axis(result)
    two = EvaluationResult(rows=rows + [{**rows[0], "input_kind": "scan-rings8-v1", "hole_rmse": 2.0}], meta={})
    assert has_beams_axis(two) and "| m | rect-v1 | 1.00 | 2.00 |" in density_markdown(density_table(two))
