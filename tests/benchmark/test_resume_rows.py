"""A benchmark resume takes only rows its run could have written (inpaintenv.values.rows)."""

from __future__ import annotations

import math
import shutil

import pytest
from hostile_rows import HOSTILE_ROWS, hole_without_truth, tamper_rows

from inpaintenv.benchmark import RunStateError, run_benchmark
from inpaintenv.data import SyntheticStreets

PROTOCOLS = ["rect-v1"]


@pytest.fixture(scope="module")
def streets():
    return SyntheticStreets(n=3, frame_shape=(24, 48))


def _run(streets, out):
    from estimators.classical import HarmonicInpainter, NearestInpainter

    return run_benchmark({"harmonic": HarmonicInpainter(), "nearest": NearestInpainter()}, streets,
                         protocols=PROTOCOLS, seeds=[0], out_dir=out, progress=False)


@pytest.fixture(scope="module")
def finished(streets, tmp_path_factory):
    out = tmp_path_factory.mktemp("run") / "run"
    return out, _run(streets, out)


def _copy(finished, tmp_path):
    out = tmp_path / "run"
    shutil.copytree(finished[0], out)
    return out, out / "rows" / "harmonic__rect-v1.jsonl"


@pytest.mark.parametrize("name", sorted(HOSTILE_ROWS))
def test_resume_refuses_a_row_its_run_could_not_have_written(name, streets, finished, tmp_path):
    edit, says = HOSTILE_ROWS[name]
    out, path = _copy(finished, tmp_path)
    tamper_rows(path, edit)
    before = path.read_bytes()
    with pytest.raises(RunStateError, match=rf"line \d+ of .*harmonic__rect-v1\.jsonl is not a row of this run: "
                                            rf".*{says}.*--no-resume"):
        _run(streets, out)
    assert path.read_bytes() == before  # nothing scored, nothing appended


def test_a_hole_without_ground_truth_is_a_skipped_frame_on_resume(streets, finished, tmp_path):
    out, path = _copy(finished, tmp_path)
    for rows in (path, out / "rows" / "nearest__rect-v1.jsonl"):  # every method's row of the frame says so
        tamper_rows(rows, hole_without_truth)
    result = _run(streets, out)
    entry = result.table[0]
    assert entry["method"] == "harmonic" and entry["n_frames"] == 3 and entry["n_skipped_hole"] == 1
    kept = [r["hole_rmse"] for r in finished[1].rows[1:3]]
    assert entry["hole_rmse"] == pytest.approx(sum(kept) / len(kept))
    assert math.isnan(result.rows[0]["hole_rmse"])


def test_a_killed_runs_partial_line_is_still_rescored(streets, finished, tmp_path):
    out, path = _copy(finished, tmp_path)
    lines = path.read_text().splitlines()
    path.write_text("\n".join(lines[:2]) + "\n" + lines[2][:40])
    result = _run(streets, out)
    strip = lambda rows: [{k: v for k, v in r.items() if k != "ms"} for r in rows]
    assert strip(result.rows) == strip(finished[1].rows)


@pytest.mark.parametrize("name", sorted(HOSTILE_ROWS))
def test_a_report_rebuilt_from_the_folder_refuses_such_a_row(name, finished, tmp_path):
    from inpaintenv.benchmark.html import write_html_report

    out, path = _copy(finished, tmp_path)
    tamper_rows(path, HOSTILE_ROWS[name][0])
    with pytest.raises(RunStateError, match=r"line \d+ of .*__rect-v1\.jsonl is not a row of this run: "):
        write_html_report(out, lambda line: None)
    assert not (out / "report.html").exists()


def test_a_report_refuses_rows_of_frames_other_than_the_runs(finished, tmp_path):
    from inpaintenv.benchmark.html import write_html_report

    out, _ = _copy(finished, tmp_path)
    for path in (out / "rows").glob("*.jsonl"):  # every row of frame 0 renamed alike: consistent, yet not the run's
        tamper_rows(path, lambda rows: [{**r, "frame_id": "x/0"} if r["index"] == 0 else r for r in rows])
    with pytest.raises(RunStateError, match="frames other than the ones run.json records"):
        write_html_report(out, lambda line: None)
    out, _ = _copy(finished, tmp_path / "untouched")
    assert write_html_report(out, lambda line: None).is_file()  # the run's own rows make a page


def test_rows_of_a_run_on_other_data_copied_in_are_refused(streets, finished, tmp_path):
    other = tmp_path / "other"
    run_benchmark({"harmonic": __import__("estimators.classical", fromlist=["x"]).HarmonicInpainter()},
                  SyntheticStreets(n=3, frame_shape=(32, 48)), protocols=PROTOCOLS, seeds=[0], out_dir=other,
                  progress=False)
    out, path = _copy(finished, tmp_path)
    shutil.copy(other / "rows" / "harmonic__rect-v1.jsonl", path)  # same frame ids and drives, other frames
    with pytest.raises(RunStateError, match=r"all_count \d+ of frame 0 is not the \d+ of the row at .*one frame has"):
        _run(streets, out)


def test_a_row_whose_mask_disagrees_with_the_other_methods_is_refused(streets, finished, tmp_path):
    out, path = _copy(finished, tmp_path)
    tamper_rows(path, lambda rows: [{**rows[0], "hole_fraction": rows[0]["hole_fraction"] / 2}, *rows[1:]])
    with pytest.raises(RunStateError, match=r"hole_fraction .* of frame 0 is not the .*one protocol and seed"):
        _run(streets, out)


@pytest.mark.parametrize("meta", [{"training_drives": {"harmonic": 5}}, {"training_drives": {"harmonic": [{}]}},
                                  {"training_drives": {"harmonic": "synthetic_s0_drive_0000"}},
                                  {"kinds": {"harmonic": 7}}, {"training_drives": [1]}])
def test_a_report_takes_only_well_formed_labels_from_a_hand_edited_results_json(meta, finished, tmp_path):
    import json

    from inpaintenv.benchmark.html import write_html_report
    from inpaintenv.files.ownership import claim

    out, _ = _copy(finished, tmp_path)
    claim(out, "results.json")  # as the benchmark's report records it
    finished[1].to_json(out / "results.json")
    doc = json.loads((out / "results.json").read_text())
    (out / "results.json").write_text(json.dumps({**doc, "meta": {**doc["meta"], **meta}}))
    page = write_html_report(out, lambda line: None).read_text()
    assert "harmonic" in page and "synthetic_s0_drive_0000 (trained" not in page
