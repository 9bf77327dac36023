"""Rows, headlines and reports mark the drives a scored model was trained on.

`--drives 2011_09_26_drive_9001_sync` reported 0.97 for a release trained on 9001 without
a word: a learned model's training drives (``training_drives_``, saved with it) now reach
``meta["training_drives"]`` of evaluate() and the benchmark, and every table and headline
marks the rows of such drives with ‡.
"""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from inpaintenv.benchmark import (
    headline_markdown,
    learned_vs_classical,
    run_benchmark,
    write_report,
)
from inpaintenv.data import ArrayDataset
from inpaintenv.evaluate import evaluate
from inpaintenv.report.results import EvaluationResult
from inpaintenv.report.tables import (
    TRAINED_MARK,
    summary_table,
    table_to_csv,
    to_markdown,
)


class Trained:
    """A 'learned' method: the median of the measured pixels, trained on drive d0."""

    training_drives_ = ("d0",)

    def predict(self, X):
        out = np.array(X, dtype=np.float32)
        for frame in out:
            frame[np.isnan(frame)] = np.median(frame[frame > 0])
        return out


class Classical(Trained):
    training_drives_ = None
    kind = "classical"  # what the headline compares against (a user's class says so)


def _data() -> ArrayDataset:
    rows = np.linspace(5.0, 40.0, 32, dtype=np.float32)[:, None] + np.zeros((1, 48), np.float32)
    return ArrayDataset(np.stack([rows + k for k in range(4)]), groups=["d0", "d0", "d1", "d1"])


def test_evaluate_records_and_tables_mark_the_training_drives(tmp_path):
    result = EvaluationResult.concat([evaluate(Trained(), _data(), name="mine", progress=False),
                                      evaluate(Classical(), _data(), name="harmonic", progress=False)])
    assert result.meta["training_drives"] == {"mine": ["d0"]}
    overall = summary_table(result)
    assert overall[0]["trained_on"] == ["d0"] and overall[0]["n_drives"] == 2 and overall[1]["trained_on"] == []
    text = to_markdown(overall)
    assert f"| mine {TRAINED_MARK} (1 of 2 drives) |" in text and "| harmonic |" in text
    assert f"{TRAINED_MARK} trained on the drive scored" in text
    per_drive = summary_table(result, ("method", "protocol", "drive"))
    text = to_markdown(per_drive, ("method", "protocol", "drive"))
    assert f"| mine {TRAINED_MARK} | rect-v1 | d0 |" in text and "| mine | rect-v1 | d1 |" in text
    table_to_csv(per_drive, tmp_path / "t.csv", ("method", "protocol", "drive"))
    cells = [r["trained_on"] for r in csv.DictReader((tmp_path / "t.csv").open())]
    assert cells == ["d0", "", "", ""]
    plain = EvaluationResult(rows=result.rows, meta={})  # no record: nothing marked
    assert TRAINED_MARK not in to_markdown(summary_table(plain))


def test_headline_marks_a_learned_model_scored_on_its_training_drive():
    result = EvaluationResult.concat([evaluate(Trained(), _data(), name="mine", progress=False),
                                      evaluate(Classical(), _data(), name="harmonic", progress=False)])
    rows = learned_vs_classical(result)
    assert [(r["drive"], r["learned_trained_on"]) for r in rows] == [("d0", ["d0"]), ("d1", [])]
    text = headline_markdown(rows)
    assert f"| rect-v1 | d0 | 2 | 0 | mine {TRAINED_MARK} " in text and "| rect-v1 | d1 | 2 | 0 | mine " in text
    assert f"{TRAINED_MARK} trained on the drive scored" in text


def test_benchmark_report_marks_them_and_a_resume_remembers(tmp_path):
    methods = {"mine": Trained(), "harmonic": Classical()}
    out = tmp_path / "run"
    result = run_benchmark(methods, _data(), out_dir=out, progress=False)
    assert result.meta["training_drives"] == {"mine": ["d0"]}
    assert json.loads((out / "run.json").read_text())["training_drives"] == {"mine": ["d0"]}
    write_report(result, out)
    md = (out / "results.md").read_text()
    assert md.count(f"mine {TRAINED_MARK}") == 3  # overall, per drive (d0), headline (d0)
    doc = json.loads((out / "results.json").read_text())
    assert doc["meta"]["training_drives"] == {"mine": ["d0"]} and doc["headline"][0]["learned_trained_on"] == ["d0"]
    # Resumed with nothing left to score and a lazy method that is never built: still marked.
    from inpaintenv.benchmark import LazyMethod

    lazy = {"mine": LazyMethod(Trained, identity="trained-median"), "harmonic": Classical()}
    run_benchmark({"mine": LazyMethod(Trained, identity="trained-median"), "harmonic": Classical()}, _data(),
                  out_dir=tmp_path / "lazy", progress=False)
    again = run_benchmark(lazy, _data(), out_dir=tmp_path / "lazy", progress=False)
    assert again.meta["training_drives"] == {"mine": ["d0"]}


@pytest.mark.kitti
def test_release_scored_on_its_training_drive_is_marked(kitti_root, tmp_path, capsys):
    # A shipped release scored on a drive it was trained on: kitti-mixed-v1 (trained on 9001).
    pytest.importorskip("torch")
    from inpaintenv.cli import main

    assert main(["benchmark", "--kitti-root", str(kitti_root), "--drives", "2011_09_26_drive_9001_sync",
                 "--n-frames", "2", "-m", "kitti-mixed-v1", "-m", "scanline", "--figure-frames", "0", "--quiet",
                 "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert f"| kitti-mixed-v1 {TRAINED_MARK} | rect-v1 |" in out
    assert f"| rect-v1 | 2011_09_26_drive_9001_sync | 2 | 0 | kitti-mixed-v1 {TRAINED_MARK} " in out
