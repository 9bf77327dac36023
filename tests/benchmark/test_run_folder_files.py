"""Every file of a benchmark run folder goes through inpaintenv.files."""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys

import pytest

from inpaintenv.files.ownership import LEDGER
from inpaintenv.cli import main
from inpaintenv.files import TEMP_PREFIX

pytest.importorskip("estimators.classical")

ARGV = ["benchmark", "-m", "constant", "--frame-shape", "32", "96", "--n-frames", "4", "--holdout", "0",
        "--figure-frames", "0", "--quiet"]
FIGURES = [*ARGV[:-3], "--figure-frames", "1", "--quiet"]
ROWS = "rows/constant__rect-v1.jsonl"
#: 200 kB of nested JSON: json.loads raises RecursionError on it.
NESTED = "[" * 100_000 + "]" * 100_000


@contextlib.contextmanager
def no_hang(seconds: int = 30):
    """Fail instead of hanging forever (a FIFO opened for reading waits for a writer)."""
    def stop(*_):
        raise TimeoutError(f"hung for {seconds} s")

    previous = signal.signal(signal.SIGALRM, stop)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


def one_line_error(capsys, argv, *words):
    """Run the CLI; it must fail with one line naming ``words``."""
    with no_hang():
        assert main(argv) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    for word in words:
        assert word in err, err
    return err


@pytest.fixture
def run(tmp_path, capsys):
    """A finished run folder."""
    out = tmp_path / "R"
    assert main([*ARGV, "--out", str(out)]) == 0
    capsys.readouterr()
    return out


def test_a_symlinked_row_file_receives_no_rows_on_resume(tmp_path, capsys, run):
    # rows/*.jsonl -> ../victim used to be read through and appended to on resume.
    victim = tmp_path / "victim"
    victim.write_text("the user's notes\n")
    (run / ROWS).unlink()
    (run / ROWS).symlink_to(victim)
    one_line_error(capsys, [*ARGV, "--out", str(run)], ROWS.split("/")[1], "symbolic link")
    assert victim.read_text() == "the user's notes\n"


def test_a_symlinked_rows_folder_is_refused(tmp_path, capsys, run):
    elsewhere = tmp_path / "elsewhere"
    (run / "rows").rename(elsewhere)
    (run / "rows").symlink_to(elsewhere)
    one_line_error(capsys, [*ARGV, "--out", str(run)], "rows", "symbolic link")


@pytest.mark.parametrize("name", ["run.json", LEDGER])
def test_deeply_nested_json_in_the_run_folder_is_one_line(capsys, run, name):
    # A RecursionError traceback before.
    (run / name).write_text(NESTED)
    one_line_error(capsys, [*ARGV, "--out", str(run)], name, "nested deeper")


def test_a_deeply_nested_row_line_is_skipped_like_a_partial_line(capsys, run):
    with open(run / ROWS, "a") as f:
        f.write(NESTED)
    assert main([*ARGV, "--out", str(run)]) == 0


def test_a_row_that_is_json_but_not_a_row_is_one_line(capsys, run):
    with open(run / ROWS, "a") as f:
        f.write('{"method": "constant", "seed": "zero", "index": 1}\n')
    one_line_error(capsys, [*ARGV, "--out", str(run)], "line 5 of", "is not a row")


def test_nested_results_json_in_a_folder_without_ledger_is_a_foreign_folder(tmp_path, capsys):
    out = tmp_path / "R"
    out.mkdir()
    (out / "results.json").write_text(NESTED)
    one_line_error(capsys, [*ARGV, "--out", str(out)], "neither empty nor a run folder")


def test_a_nested_figure_stamp_is_redrawn(capsys, run):
    assert main([*FIGURES, "--out", str(run)]) == 0
    (run / "figures" / "figures.json").write_text(NESTED)
    with no_hang():
        assert main([*FIGURES, "--out", str(run)]) == 0
    assert json.loads((run / "figures" / "figures.json").read_text())["stamp"]


@pytest.mark.parametrize("name", ["run.json", LEDGER, ROWS, "figures/figures.json"])
def test_a_fifo_named_like_a_run_file_is_refused_at_once(capsys, run, name):
    # A FIFO opened for reading waits forever for a writer.
    argv = FIGURES if name.startswith("figures/") else ARGV
    if name.startswith("figures/"):
        assert main([*argv, "--out", str(run)]) == 0
    (run / name).unlink(missing_ok=True)
    os.mkfifo(run / name)
    one_line_error(capsys, [*argv, "--out", str(run)], name.split("/")[-1], "FIFO")


def test_stale_temporaries_of_a_killed_writer_are_removed_at_start(capsys, run):
    # Hidden temporaries of a writer killed with -9 stayed forever.
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True,
                          text=True, check=True)
    dead_pid = int(dead.stdout)
    (run / "figures").mkdir(exist_ok=True)
    stale = [run / f"{TEMP_PREFIX}{dead_pid}-0123abcd.json", run / "rows" / f"{TEMP_PREFIX}{dead_pid}-4567.jsonl",
             run / "figures" / f"{TEMP_PREFIX}{dead_pid}-89ab.png"]
    alive = run / f"{TEMP_PREFIX}{os.getppid()}-cdef.json"  # its writer still runs
    for path in [*stale, alive]:
        path.write_text("half")
    assert main([*ARGV, "--out", str(run)]) == 0
    assert not any(p.exists() for p in stale)
    assert alive.exists()


def test_results_readers_refuse_nested_json_and_fifos(tmp_path):
    from inpaintenv.report.results import EvaluationResult
    from inpaintenv.exceptions import JSONFileError, UnsafeFileError

    (tmp_path / "results.json").write_text(NESTED)
    with pytest.raises(JSONFileError, match="nested deeper"):
        EvaluationResult.from_json(tmp_path / "results.json")
    os.mkfifo(tmp_path / "results.csv")
    with no_hang(), pytest.raises(UnsafeFileError, match="FIFO"):
        EvaluationResult.from_csv(tmp_path / "results.csv")


def test_row_appends_never_follow_a_link(tmp_path):
    # evaluate's partial-rows.jsonl and benchmark's rows/*.jsonl share append_rows.
    from inpaintenv.benchmark.rows import append_rows, read_rows
    from inpaintenv.exceptions import UnsafeFileError

    victim = tmp_path / "victim"
    victim.write_text("mine\n")
    (tmp_path / "partial-rows.jsonl").symlink_to(victim)
    with pytest.raises(UnsafeFileError, match="symbolic link"):
        append_rows(tmp_path / "partial-rows.jsonl", [{"method": "m", "seed": 0, "index": 0}])
    with pytest.raises(UnsafeFileError, match="symbolic link"):
        read_rows(tmp_path / "partial-rows.jsonl")
    assert victim.read_text() == "mine\n"
