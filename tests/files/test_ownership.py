"""Run folders replace and delete only the files a run recorded writing."""

from __future__ import annotations

import json

import numpy as np
import pytest

from inpaintenv.benchmark import run_benchmark
from inpaintenv.files.ownership import LEDGER, ForeignFolderError, check_folder, claim, remove
from inpaintenv.cli import main

pytest.importorskip("estimators.classical")

DATA = ["--frame-shape", "32", "96", "--n-frames", "4", "--quiet"]


def bench(out, *extra):
    return main(["benchmark", "-m", "constant", *DATA, "--holdout", "0", "--figure-frames", "0", "--out", str(out),
                 *extra])


def one_line_naming(capsys, folder, file):
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert f"--out {folder} " in err and str(folder / file) in err, err
    return err


def test_benchmark_refuses_a_folder_of_someone_elses_files(tmp_path, capsys):
    out = tmp_path / "d"
    (out / "figures").mkdir(parents=True)
    (out / "results.md").write_text("my notes")
    (out / "figures" / "frame_0000.png").write_bytes(b"my picture")
    assert bench(out) == 1
    err = one_line_naming(capsys, out, "results.md")
    assert "neither empty nor a run folder" in err
    assert (out / "results.md").read_text() == "my notes"
    assert (out / "figures" / "frame_0000.png").read_bytes() == b"my picture"
    assert sorted(p.name for p in out.iterdir()) == ["figures", "results.md"]  # not even a lock file


def test_a_users_file_at_a_run_path_of_a_run_folder_is_refused_not_replaced(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["benchmark", "-m", "constant", *DATA, "--holdout", "0", "--figure-frames", "1", "--out", str(out)]) == 0
    ledger = set(json.loads((out / LEDGER).read_text())["files"])
    assert {"run.json", "results.md", "results.json", "rows/constant__rect-v1.jsonl",
            "figures/frame_0000.png", "figures/figures.json"} <= ledger
    # A stray panel the figure step would have deleted, and a table the report would have replaced.
    (out / "figures" / "frame_0003.png").write_bytes(b"mine")
    assert main(["benchmark", "-m", "constant", *DATA, "--holdout", "0", "--figure-frames", "1", "--out", str(out)]) == 1
    one_line_naming(capsys, out, "figures/frame_0003.png")
    assert (out / "figures" / "frame_0003.png").read_bytes() == b"mine"
    # Other files of a run folder (a README, the temporary file of a write a kill interrupted) are
    # left alone and do not stop a run.
    (out / "figures" / "frame_0003.png").unlink()
    (out / "README.txt").write_text("about this run")
    (out / "figures" / ".frame_0000.png.x1y2.tmp.png").write_bytes(b"half")  # an earlier version's name
    (out / "figures" / ".inpaintenv-tmp-999999-0a1b.png").write_bytes(b"half")
    assert main(["benchmark", "-m", "constant", *DATA, "--holdout", "0", "--figure-frames", "1", "--out", str(out)]) == 0
    assert (out / "README.txt").read_text() == "about this run"


def test_no_resume_deletes_only_the_row_files_a_run_wrote(tmp_path, capsys):
    out = tmp_path / "run"
    assert bench(out) == 0
    (out / "rows" / "mine__rect-v1.jsonl").write_text('{"my": "rows"}\n')
    assert bench(out, "--no-resume") == 1
    one_line_naming(capsys, out, "rows/mine__rect-v1.jsonl")
    assert (out / "rows" / "mine__rect-v1.jsonl").read_text() == '{"my": "rows"}\n'
    assert (out / "rows" / "constant__rect-v1.jsonl").is_file()  # refused before anything was deleted


def test_python_run_refuses_a_foreign_folder(tmp_path, small_gt):
    (tmp_path / "keep.txt").write_text("x")
    with pytest.raises(ForeignFolderError, match="keep.txt"):
        run_benchmark({"ten": lambda x: np.where(np.isnan(x), 10.0, x)}, small_gt, out_dir=tmp_path, progress=False)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["keep.txt"]


def test_evaluate_out_refuses_someone_elses_table(tmp_path, capsys):
    out = tmp_path / "e"
    out.mkdir()
    (out / "table.md").write_text("my table")
    argv = ["evaluate", "-m", "constant", *DATA, "--out", str(out)]
    assert main(argv) == 1
    one_line_naming(capsys, out, "table.md")
    assert (out / "table.md").read_text() == "my table"
    (out / "table.md").unlink()
    assert main(argv) == 0  # an empty folder is fine, and a rerun replaces its own files
    assert main(argv) == 0
    assert json.loads((out / LEDGER).read_text())["files"] == ["results.csv", "results.json", "table.csv",
                                                               "table.md"]


def test_score_refuses_someone_elses_files(tmp_path, small_gt):
    from inpaintenv.data import ArrayDataset
    from inpaintenv.data.io import read_depth_png, write_depth_png
    from inpaintenv.submission import export, score

    source = ArrayDataset(small_gt)
    manifest = export(tmp_path / "in", source, progress=False)
    for item in manifest.items:
        x = read_depth_png(tmp_path / "in" / item.input)
        write_depth_png(tmp_path / "pred" / item.input, np.where(x > 0, x, 10.0))
    out = tmp_path / "run"
    out.mkdir()
    (out / "results.json").write_text('{"mine": true}')
    with pytest.raises(ForeignFolderError, match="results.json"):
        score(manifest, tmp_path / "pred", source=source, out_dir=out)
    assert (out / "results.json").read_text() == '{"mine": true}'
    assert sorted(p.name for p in out.iterdir()) == ["results.json"]
    (out / "results.json").unlink()
    score(manifest, tmp_path / "pred", source=source, out_dir=out)
    assert (out / "run.json").is_file() and (out / LEDGER).is_file()


def test_a_run_folder_from_before_ledgers_is_adopted(tmp_path, capsys):
    out = tmp_path / "old"
    assert bench(out) == 0
    (out / LEDGER).unlink()  # as written before ledgers existed
    assert bench(out) == 0
    assert "results.md" in json.loads((out / LEDGER).read_text())["files"]


def test_claim_and_remove_touch_only_recorded_files(tmp_path):
    (tmp_path / "theirs.csv").write_text("x")
    with pytest.raises(ForeignFolderError, match="neither empty nor a run folder"):
        check_folder(tmp_path)
    (tmp_path / "theirs.csv").unlink()
    claim(tmp_path, "table.csv")
    (tmp_path / "table.csv").write_text("ours")
    (tmp_path / "results.csv").write_text("theirs")
    with pytest.raises(ForeignFolderError, match="results.csv"):
        claim(tmp_path, "results.csv")
    assert not remove(tmp_path, "results.csv") and (tmp_path / "results.csv").exists()
    assert remove(tmp_path, "table.csv") and not (tmp_path / "table.csv").exists()
