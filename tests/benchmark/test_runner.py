"""The resumable benchmark runner and its report."""

from __future__ import annotations

import json

import numpy as np
import pytest

from inpaintenv.benchmark import (
    RunMismatchError,
    RunStateError,
    method_identity,
    run_benchmark,
    summary_table,
    write_report,
)
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

    # The same model under a wrapper: say so, or the resume would (rightly) be refused.
    counting.identity = method_identity(median_fill)

    resumed = run_benchmark(
        {"median": counting, "ten": ten_metres}, dataset, protocols=["rect-v1", "freeform-v1"],
        seeds=[0, 3], out_dir=out, progress=False, batch_size=2,
    )
    assert 0 < len(calls) < 2 * 2 * len(dataset)  # only the missing frames were scored
    strip = lambda rows: [{k: v for k, v in r.items() if k != "ms"} for r in rows]
    assert strip(resumed.rows) == strip(full.rows)


def test_each_method_is_warmed_up_once_untimed(dataset, tmp_path):
    calls = []

    def counting(x):
        calls.append(x.copy())
        return median_fill(x)

    res = run_benchmark({"median": counting}, dataset, protocols=["rect-v1", "freeform-v1"], seeds=[0, 3],
                        out_dir=tmp_path, progress=False, batch_size=2)
    # one warm-up call for the whole run (not per seed or protocol), then every scored frame once
    assert len(calls) == 1 + len(res.rows) == 1 + 2 * 2 * len(dataset)
    np.testing.assert_array_equal(calls[0], calls[1])  # the warm-up sees the first scored input


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


# --- method identity on resume ----------------------------------------------------------
def test_rows_of_another_model_under_the_same_name_are_not_reused(dataset, tmp_path):
    run_benchmark({"m": median_fill}, dataset, out_dir=tmp_path, progress=False)
    with pytest.raises(RunMismatchError, match=r"rows for 'm' in .* were made by .*median_fill, not .*ten_metres"):
        run_benchmark({"m": ten_metres}, dataset, out_dir=tmp_path, progress=False)
    # --no-resume starts over and scores the new model.
    res = run_benchmark({"m": ten_metres}, dataset, out_dir=tmp_path, progress=False, resume=False)
    fresh = run_benchmark({"ten": ten_metres}, dataset, out_dir=tmp_path / "fresh", progress=False)
    assert [r["hole_rmse"] for r in res.rows] == [r["hole_rmse"] for r in fresh.rows]


def test_estimator_parameters_are_part_of_the_identity(dataset, tmp_path):
    classical = pytest.importorskip("estimators.classical")
    run_benchmark({"h": classical.HarmonicInpainter()}, dataset, out_dir=tmp_path, progress=False)
    # Speed-only parameters may change between a run and its resume...
    again = run_benchmark({"h": classical.HarmonicInpainter(n_jobs=2)}, dataset, out_dir=tmp_path, progress=False)
    assert len(again.rows) == len(dataset)
    # ...parameters that change the output may not.
    with pytest.raises(RunMismatchError, match=r"HarmonicInpainter\(.*'inverse', False.*not .*'inverse', True"):
        run_benchmark({"h": classical.HarmonicInpainter(inverse=True)}, dataset, out_dir=tmp_path, progress=False)


def test_lazy_identity_is_checked_without_building(dataset, tmp_path):
    from inpaintenv.benchmark import LazyMethod

    built = []

    def factory():
        built.append(1)
        return median_fill

    run_benchmark({"m": LazyMethod(factory, identity="checkpoint:aaa")}, dataset, out_dir=tmp_path, progress=False)
    assert built == [1]
    # Unchanged identity, nothing left to score: resumed without building the model.
    res = run_benchmark({"m": LazyMethod(factory, identity="checkpoint:aaa")}, dataset, out_dir=tmp_path,
                        progress=False)
    assert built == [1] and len(res.rows) == len(dataset)
    with pytest.raises(RunMismatchError, match="made by checkpoint:aaa, not checkpoint:bbb"):
        run_benchmark({"m": LazyMethod(factory, identity="checkpoint:bbb")}, dataset, out_dir=tmp_path,
                      progress=False)
    assert built == [1]


def test_run_without_recorded_identities_still_resumes(dataset, tmp_path):
    first = run_benchmark({"m": median_fill}, dataset, out_dir=tmp_path, progress=False)
    # A run.json written before identities were recorded: the rows' maker is unknown.
    state = json.loads((tmp_path / "run.json").read_text())
    del state["methods"]
    (tmp_path / "run.json").write_text(json.dumps(state))
    calls = []

    def counting(x):
        calls.append(1)
        return median_fill(x)

    res = run_benchmark({"m": counting}, dataset, out_dir=tmp_path, progress=False)
    assert calls == [] and res.rows == first.rows


def test_no_resume_discards_every_row_file(dataset, tmp_path):
    run_benchmark({"a": median_fill}, dataset, seeds=[0], out_dir=tmp_path, progress=False)
    run_benchmark({"b": ten_metres}, dataset, seeds=[1], out_dir=tmp_path, progress=False, resume=False)
    assert [p.name for p in (tmp_path / "rows").glob("*.jsonl")] == ["b__rect-v1.jsonl"]


# --- argument validation ----------------------------------------------------------------
@pytest.mark.parametrize(
    ("kw", "error", "match"),
    [
        ({"seeds": []}, ValueError, "seeds is empty"),
        ({"seeds": [0, 0]}, ValueError, r"seeds must be distinct .*\(\[0\] repeated\)"),
        ({"seeds": [-1]}, ValueError, r"seeds must be distinct non-negative integers, got \[-1\]"),
        ({"seeds": "12"}, TypeError, "seeds must be distinct non-negative integers, got '12'"),
        ({"seeds": [1.5]}, TypeError, r"seeds must be .*integers, got \[1.5\]"),
        ({"seeds": [True]}, TypeError, r"seeds must be .*integers, got \[True\]"),
        ({"n_frames": -2}, ValueError, "n_frames must be >= 1, got -2"),
        ({"n_frames": 0}, ValueError, "n_frames must be >= 1"),
        ({"n_frames": 2.5}, TypeError, "n_frames must be an integer, got 2.5"),
        ({"protocols": []}, ValueError, "protocols is empty"),
        ({"protocols": ["rect-v1", "rect-v1"]}, ValueError, "protocols must be distinct"),
        ({"protocols": ["nope"]}, KeyError, "nope"),
        ({"batch_size": 0}, ValueError, "batch_size must be >= 1"),
    ],
)
def test_invalid_runs_are_refused(dataset, tmp_path, kw, error, match):
    with pytest.raises(error, match=match):
        run_benchmark({"m": median_fill}, dataset, out_dir=tmp_path, progress=False, **kw)
    assert not (tmp_path / "run.json").exists()  # refused before touching the folder


def test_no_methods_is_refused(dataset, tmp_path):
    with pytest.raises(ValueError, match="methods is empty"):
        run_benchmark({}, dataset, out_dir=tmp_path, progress=False)


def test_a_single_protocol_name_or_seed_is_one_protocol_or_seed(dataset, tmp_path):
    res = run_benchmark({"m": median_fill}, dataset, protocols="freeform-v1", seeds=3, out_dir=tmp_path,
                        progress=False)
    assert {(r["protocol"], r["seed"]) for r in res.rows} == {("freeform-v1", 3)}
    assert len(res.rows) == len(dataset)


def test_corrupt_resume_state_names_the_file(dataset, tmp_path):
    run_benchmark({"m": median_fill}, dataset, out_dir=tmp_path, progress=False)
    (tmp_path / "run.json").write_text('{"source": ')
    with pytest.raises(RunStateError, match=r"cannot read the resume state .*run\.json .*--no-resume"):
        run_benchmark({"m": median_fill}, dataset, out_dir=tmp_path, progress=False)
    (tmp_path / "run.json").write_text("[]")
    with pytest.raises(RunStateError, match=r"run\.json is not a benchmark resume state"):
        run_benchmark({"m": median_fill}, dataset, out_dir=tmp_path, progress=False)
    # Starting over replaces it.
    res = run_benchmark({"m": median_fill}, dataset, out_dir=tmp_path, progress=False, resume=False)
    assert len(res.rows) == len(dataset)


def holes_at_zero(x: np.ndarray) -> np.ndarray:
    return np.nan_to_num(x, nan=0.0)


def test_unfilled_pixels_follow_the_run_or_the_method_policy(dataset, tmp_path):
    from inpaintenv.benchmark import LazyMethod
    from inpaintenv.exceptions import MethodOutputError

    kw = {"protocols": "rect-v1", "seeds": 0, "progress": False}
    # Refused by default, with the count, naming the method.
    with pytest.raises(MethodOutputError, match=r"method 'zeros': prediction is 0 m \(unfilled\) at \d+ hole pixels"):
        run_benchmark({"zeros": holes_at_zero}, dataset, out_dir=tmp_path / "a", **kw)
    # A method's own policy (the registry's "zero" for the study's hole-only baselines) ...
    lazy = {"zeros": LazyMethod(lambda: holes_at_zero, unfilled="zero"), "ten": ten_metres}
    res = run_benchmark(lazy, dataset, out_dir=tmp_path / "b", **kw)
    assert res.meta["unfilled"] == {"zeros": "zero", "ten": "error"}
    # ... and a run-wide one, which is part of the run's fingerprint.
    ipol = run_benchmark(lazy, dataset, out_dir=tmp_path / "c", unfilled="interpolate", **kw)
    assert ipol.meta["unfilled"] == {"zeros": "interpolate", "ten": "interpolate"}
    assert ipol.table[0]["hole_rmse"] < res.table[0]["hole_rmse"]
    with pytest.raises(RunMismatchError, match="holds results of a different run"):
        run_benchmark(lazy, dataset, out_dir=tmp_path / "c", unfilled="zero", **kw)
    with pytest.raises(ValueError, match="unfilled must be one of"):
        run_benchmark(lazy, dataset, out_dir=tmp_path / "d", unfilled="skip", **kw)
    # A default run writes no policy into run.json: folders of earlier versions resume.
    assert "unfilled" not in json.loads((tmp_path / "b" / "run.json").read_text())
