"""One run per run folder."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import textwrap

import pytest

from inpaintenv.files.lock import LOCK_FILE, RunLockedError, run_lock
from inpaintenv.cli import main

pytest.importorskip("estimators.classical")

ARGV = ["benchmark", "-m", "constant", "--frame-shape", "32", "96", "--n-frames", "4", "--holdout", "0",
        "--figure-frames", "0", "--quiet"]

# A process that takes the lock and waits for stdin to close.
HOLDER = textwrap.dedent("""
    import sys
    from inpaintenv.files.lock import run_lock
    with run_lock(sys.argv[1]):
        print("locked", flush=True)
        sys.stdin.read()
""")


@pytest.fixture
def holder(tmp_path):
    proc = subprocess.Popen([sys.executable, "-c", HOLDER, str(tmp_path)], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "locked"
    yield proc
    proc.stdin.close()
    proc.wait(timeout=30)


def test_second_run_on_the_same_out_is_refused_naming_the_holder(tmp_path, capsys, holder):
    assert main([*ARGV, "--out", str(tmp_path)]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert f"is in use by another run (pid {holder.pid} on {socket.gethostname()}, started " in err
    assert not (tmp_path / "rows").exists() or not any((tmp_path / "rows").iterdir())  # did no work


def test_lock_is_released_when_the_holder_exits(tmp_path, capsys, holder):
    holder.stdin.close()
    holder.wait(timeout=30)
    assert main([*ARGV, "--out", str(tmp_path)]) == 0
    assert (tmp_path / LOCK_FILE).read_text() == ""  # released on exit


def test_stale_lock_of_a_killed_run_is_taken_over(tmp_path, capsys):
    proc = subprocess.Popen([sys.executable, "-c", HOLDER, str(tmp_path)], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "locked"
    proc.kill()  # SIGKILL: no cleanup, the file still names it
    proc.wait(timeout=30)
    assert json.loads((tmp_path / LOCK_FILE).read_text())["pid"] == proc.pid
    argv = [a for a in ARGV if a != "--quiet"]
    assert main([*argv, "--out", str(tmp_path)]) == 0
    err = capsys.readouterr().err
    assert f"taking over the stale lock of {tmp_path} (pid {proc.pid} on " in err and "that process is gone" in err


def test_lock_is_reentrant_in_a_process_and_released_on_errors(tmp_path):
    with pytest.raises(KeyboardInterrupt), run_lock(tmp_path):
        with run_lock(tmp_path):  # the CLI and run_benchmark both take it
            info = json.loads((tmp_path / LOCK_FILE).read_text())
            assert info["pid"] == os.getpid()
        raise KeyboardInterrupt
    with run_lock(tmp_path):  # free again
        pass


def test_out_that_is_a_file_is_refused(tmp_path):
    f = tmp_path / "file"
    f.write_text("x")
    with pytest.raises(NotADirectoryError, match="is a file"), run_lock(f):
        pass


def test_locked_error_is_a_user_error():
    from inpaintenv.cli import USER_ERRORS

    assert issubclass(RunLockedError, USER_ERRORS)


def _score_argv(tmp_path):
    """``inpaintenv score`` of a tiny export whose predictions are its inputs with the holes at 10 m."""
    import numpy as np

    from inpaintenv.data.io import read_depth_png, write_depth_png
    from inpaintenv.submission import read_manifest

    assert main(["export", "--n-frames", "4", "--frame-shape", "32", "96", "--holdout", "0", "--trusted", "--out",
                 str(tmp_path / "in"), "-q"]) == 0
    for item in read_manifest(tmp_path / "in.key.json").items:
        x = read_depth_png(tmp_path / "in" / item.input)
        write_depth_png(tmp_path / "pred" / item.input, np.where(x > 0, x, 10.0))
    return ["score", "--manifest", str(tmp_path / "in.key.json"), "--predictions", str(tmp_path / "pred"),
            "--name", "mine", "--figure-frames", "0", "-q"]


@pytest.mark.parametrize("command", ["benchmark", "train", "score"])
def test_a_symlinked_lock_file_is_refused_and_its_target_untouched(tmp_path, capsys, command):
    # run.lock -> ../victim used to be opened "a+" and truncated through the link.
    if command == "train":
        pytest.importorskip("torch")
    victim = tmp_path / "victim"
    victim.write_text("the user's data\n")
    out = tmp_path / "R"
    out.mkdir()
    (out / LOCK_FILE).symlink_to("../victim")
    argv = {
        "benchmark": ARGV,
        "train": ["train", "--preset", "smoke", "--n-frames", "8", "--frame-shape", "64", "192", "--quiet"],
        "score": _score_argv(tmp_path) if command == "score" else [],
    }[command]
    assert main([*argv, "--out", str(out)]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "run.lock" in err and "symbolic link" in err, err
    assert victim.read_text() == "the user's data\n"
    assert sorted(p.name for p in out.iterdir()) == [LOCK_FILE]


def test_a_fifo_lock_file_is_refused_at_once(tmp_path):
    # A FIFO named run.lock must not block the run.
    from inpaintenv.exceptions import UnsafeFileError

    os.mkfifo(tmp_path / LOCK_FILE)
    with pytest.raises(UnsafeFileError, match="FIFO"), run_lock(tmp_path):
        pass
