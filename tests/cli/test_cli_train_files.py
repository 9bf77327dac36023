"""``inpaintenv train --out``: the ledger of benchmark's run folders, and files through inpaintenv.files."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from inpaintenv.files.ownership import LEDGER
from inpaintenv.cli import main
from inpaintenv.files import TEMP_PREFIX

pytest.importorskip("torch")

SMOKE = ["train", "--preset", "smoke", "--n-frames", "8", "--frame-shape", "64", "192", "--quiet"]
NESTED = "[" * 100_000 + "]" * 100_000


def refused(capsys, out, *words):
    """``train --out out`` fails with one line naming ``words``."""
    assert main([*SMOKE, "--out", str(out)]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    for word in words:
        assert word in err, err


@pytest.fixture
def trained(tmp_path, capsys):
    out = tmp_path / "run"
    assert main([*SMOKE, "--out", str(out)]) == 0
    capsys.readouterr()
    return out


@pytest.mark.parametrize("name", ["loss.png", "training_log.json", "model/config.json"])
def test_a_users_file_at_a_train_path_is_refused_and_nothing_written(tmp_path, capsys, name):
    # Train overwrote the user's loss.png, training_log.json and model/config.json.
    out = tmp_path / "mine"
    (out / name).parent.mkdir(parents=True, exist_ok=True)
    (out / name).write_text("the user's own\n")
    before = sorted(p.relative_to(out).as_posix() for p in out.rglob("*"))
    refused(capsys, out, str(out / name))
    assert (out / name).read_text() == "the user's own\n"
    assert sorted(p.relative_to(out).as_posix() for p in out.rglob("*")) == before


def test_a_users_loss_png_in_a_benchmark_run_folder_is_refused(tmp_path, capsys):
    out = tmp_path / "bench"
    pytest.importorskip("estimators.classical")
    assert main(["benchmark", "-m", "constant", "--frame-shape", "32", "96", "--n-frames", "4", "--holdout", "0",
                 "--figure-frames", "0", "--quiet", "--out", str(out)]) == 0
    (out / "loss.png").write_bytes(b"mine")
    capsys.readouterr()
    refused(capsys, out, "loss.png")
    assert (out / "loss.png").read_bytes() == b"mine"


def test_train_records_its_files_and_a_rerun_replaces_only_them(capsys, trained):
    owned = set(json.loads((trained / LEDGER).read_text())["files"])
    assert {"train_args.json", "training_log.json", "loss.png", "model/config.json"} <= owned
    (trained / "notes.txt").write_text("mine")
    assert main([*SMOKE, "--out", str(trained), "--seed", "3"]) == 0  # another run into the same folder
    assert (trained / "notes.txt").read_text() == "mine"


def test_a_training_folder_from_before_ledgers_is_adopted(capsys, trained):
    (trained / LEDGER).unlink()
    assert main([*SMOKE, "--out", str(trained), "--seed", "3"]) == 0
    assert "loss.png" in json.loads((trained / LEDGER).read_text())["files"]


def test_checkpoints_without_a_record_are_a_training_folder(capsys, trained):
    # A fit(checkpoint_dir=OUT/checkpoints) from Python, or a training from before train_args.json.
    for name in (LEDGER, "train_args.json", "training_log.json", "loss.png"):
        (trained / name).unlink()
    assert main([*SMOKE, "--out", str(trained)]) == 0
    assert "holds checkpoints of an earlier run" in capsys.readouterr().err


def test_nested_train_args_start_a_new_run_without_a_traceback(capsys, trained):
    # json.loads raised RecursionError on 200 kB of nesting.
    (trained / "train_args.json").write_text(NESTED)
    assert main([*SMOKE, "--out", str(trained)]) == 0
    assert json.loads((trained / "train_args.json").read_text())["finished"] is True


def test_a_fifo_at_a_train_path_is_refused_at_once(tmp_path, capsys):
    # Nothing may wait on a FIFO named like one of train's files.
    out = tmp_path / "fifo"
    out.mkdir()
    os.mkfifo(out / "loss.png")
    refused(capsys, out, "loss.png")


def test_a_symlinked_model_folder_is_refused(tmp_path, capsys, trained):
    elsewhere = tmp_path / "elsewhere"
    (trained / "model").rename(elsewhere)
    (trained / "model").symlink_to(elsewhere)
    refused(capsys, trained, "model", "symbolic link")


def test_stale_temporaries_of_a_killed_training_are_removed(capsys, trained):
    # Hidden temporaries of a writer killed with -9 stayed forever.
    dead = int(subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True,
                              text=True, check=True).stdout)
    stale = [trained / f"{TEMP_PREFIX}{dead}-0123.png", trained / "model" / f"{TEMP_PREFIX}{dead}-4567.json"]
    for path in stale:
        path.write_text("half")
    assert main([*SMOKE, "--out", str(trained)]) == 0  # finished already: nothing to train, still cleaned
    assert not any(p.exists() for p in stale)
