"""The resumable benchmark runner and its report."""

from __future__ import annotations

import json

import numpy as np
import pytest

from inpaintenv.benchmark import RunMismatchError, run_benchmark, summary_table, write_report
from inpaintenv.data import ArrayDataset


def median_fill(x: np.ndarray) -> np.ndarray:
    return np.where(np.isnan(x), np.nanmedian(np.where(x > 0, x, np.nan)), x)


def ten_metres(x: np.ndarray) -> np.ndarray:
    return np.where(np.isnan(x), 10.0, x)


@pytest.fixture
def dataset(small_gt):
    frames = np.concatenate([small_gt, small_gt[::-1] + 1.0])
    return ArrayDataset(frames, groups=["d0", "d0", "d0", "d1", "d1", "d1"])


def run(dataset, out, **kw):
    return run_benchmark(
        {"median": median_fill, "ten": ten_metres}, dataset, protocols=["rect-v1", "freeform-v1"],
        seeds=[0, 3], out_dir=out, progress=False, batch_size=2, **kw,
    )


def test_rows_cover_every_method_protocol_seed_frame(dataset, tmp_path):
    res = run(dataset, tmp_path)
    assert len(res.rows) == 2 * 2 * 2 * len(dataset)
    keys = {(r["method"], r["protocol"], r["seed"], r["index"]) for r in res.rows}
    assert len(keys) == len(res.rows)


def test_killed_run_resumes_to_the_same_result(dataset, tmp_path):
    full = run(dataset, tmp_path / "full")
    out = tmp_path / "killed"
    run(dataset, out)
    # Simulate a kill: drop the last rows of one file and leave a half-written line.
    path = out / "rows" / "median__rect-v1.jsonl"
    lines = path.read_text().splitlines()
    path.write_text("\n".join(lines[:5]) + "\n" + lines[5][: len(lines[5]) // 2])
    calls = []

    def counting(x):
        calls.append(1)
        return median_fill(x)

    resumed = run_benchmark(
        {"median": counting, "ten": ten_metres}, dataset, protocols=["rect-v1", "freeform-v1"],
        seeds=[0, 3], out_dir=out, progress=False, batch_size=2,
    )
    assert 0 < len(calls) < 2 * 2 * len(dataset)  # only the missing frames were scored
    strip = lambda rows: [{k: v for k, v in r.items() if k != "ms"} for r in rows]
    assert strip(resumed.rows) == strip(full.rows)


def test_resume_into_a_different_run_is_refused(dataset, tmp_path):
    run(dataset, tmp_path)
    with pytest.raises(RunMismatchError, match="different run"):
        run_benchmark({"ten": ten_metres}, dataset, seeds=[1], out_dir=tmp_path, progress=False)
    # --no-resume overwrites
    res = run_benchmark({"ten": ten_metres}, dataset, seeds=[1], out_dir=tmp_path, progress=False, resume=False)
    assert {r["seed"] for r in res.rows} == {1}


def test_report_files_and_intervals(dataset, tmp_path):
    res = run(dataset, tmp_path)
    paths = write_report(res, tmp_path / "report", meta={"command": "test"})
    doc = json.loads(paths["json"].read_text())
    assert len(doc["rows"]) == len(res.rows)
    assert doc["meta"]["command"] == "test"
    assert doc["environment"]["versions"]["numpy"] == np.__version__
    table = summary_table(res)
    assert len(table) == 4
    for entry in table:
        assert entry["hole_rmse_low"] <= entry["hole_rmse"] <= entry["hole_rmse_high"]
        rows = [r for r in res.rows if (r["method"], r["protocol"]) == (entry["method"], entry["protocol"])]
        assert entry["hole_rmse"] == pytest.approx(np.nanmean([r["hole_rmse"] for r in rows]))
    md = paths["markdown"].read_text()
    assert "| median | rect-v1 |" in md and "±" in md and "## Per drive" in md
    assert paths["csv"].read_text().count("\n") == len(res.rows) + 1


def test_optional_methods_that_cannot_be_built_are_skipped(dataset, tmp_path):
    from inpaintenv.benchmark import LazyMethod

    def missing():
        raise ImportError("no torch here")

    messages = []
    res = run_benchmark(
        {"gone": LazyMethod(missing, optional=True), "ten": ten_metres}, dataset,
        out_dir=tmp_path, progress=False, log=messages.append,
    )
    assert res.methods == ["ten"]
    assert any("skipping 'gone'" in m and "no torch here" in m for m in messages)
    # A method the user asked for by name is not optional: the error surfaces.
    with pytest.raises(ImportError, match="no torch"):
        run_benchmark({"gone": LazyMethod(missing)}, dataset, out_dir=tmp_path, progress=False)
