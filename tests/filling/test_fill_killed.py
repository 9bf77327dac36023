"""A ``fill`` killed (SIGKILL) between the outputs of one input: rerunning the same command finishes it.

With ``--format both --confidence`` each input has six outputs (``_low``/``_high`` in both
formats, then the PNG and the ``.npy``). A child process runs the command and kills itself
with SIGKILL at a chosen output (before it, or with its temporary written but not renamed);
the rerun must exit 0 and leave exactly what an uninterrupted run leaves. The recovery itself
(an intent line in the ledger, no record after it) is also checked without a child.
"""

from __future__ import annotations

import hashlib
import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from inpaintenv.cli import main
from inpaintenv.data import SyntheticStreets
from inpaintenv.files.lock import LOCK_FILE
from inpaintenv.filling import fill
from inpaintenv.filling.ledger import LEDGER

pytestmark = pytest.mark.skipif(not hasattr(signal, "SIGKILL"), reason="SIGKILL is POSIX")

REPO = Path(__file__).resolve().parents[2]
#: Outputs per input of :func:`_argv`.
PER_INPUT = 6

#: Runs ``fill`` (argv after the first two arguments) and SIGKILLs itself at output number
#: ``argv[1]`` (counted over the run): before it (``"before"``) or once its temporary is written
#: but not yet renamed into place (``"mid"``).
CHILD = r"""
import os, signal, sys
import inpaintenv.filling.write as fw
at, mode = int(sys.argv[1]), sys.argv[2]
count = [0]
original = fw.write_atomic

def write_atomic(path, write, what="", *, within=None):
    if count[0] == at and mode == "before":
        os.kill(os.getpid(), signal.SIGKILL)
    def inner(tmp):
        write(tmp)
        if count[0] == at and mode == "mid":
            os.kill(os.getpid(), signal.SIGKILL)
    done = original(path, inner, what, within=within)
    count[0] += 1
    return done

fw.write_atomic = write_atomic
from inpaintenv.cli import main
sys.exit(main(sys.argv[3:]))
"""


def _argv(inputs: Path, out: Path) -> list[str]:
    return ["fill", str(inputs), "--out", str(out), "-m", "scanline", "--format", "both", "--confidence", "0.9",
            "--batch-size", "1", "-q"]


def _outputs(out: Path) -> dict[str, str]:
    """Every file of ``out`` but the run's own (ledger, lock), by content."""
    return {p.relative_to(out).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(out.rglob("*")) if p.is_file() and p.name not in (LEDGER, LOCK_FILE)}


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("inputs")
    streets = SyntheticStreets(n=2, frame_shape=(32, 64), kind="velodyne_raw", seed=4)
    for k in range(2):
        x = np.asarray(streets[k], np.float32)
        x[8:20, 16:40] = np.nan
        np.save(folder / f"f{k}.npy", x)
    return folder


@pytest.fixture(scope="module")
def reference(inputs, tmp_path_factory) -> dict[str, str]:
    out = tmp_path_factory.mktemp("reference") / "out"
    assert main(_argv(inputs, out)) == 0
    files = _outputs(out)
    assert len(files) == 2 * PER_INPUT
    return files


#: Where the children kill themselves: before the first output of the first input, after one of its
#: six, before its last, with its third's temporary written but not renamed, after one of the second's.
KILLS = [(0, "before"), (1, "before"), (PER_INPUT - 1, "before"), (2, "mid"), (PER_INPUT + 1, "before")]


def test_a_rerun_finishes_what_a_killed_run_left(inputs, reference, tmp_path, capsys):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}
    outs = [tmp_path / f"out_{at}_{mode}" for at, mode in KILLS]
    children = [subprocess.Popen([sys.executable, "-c", CHILD, str(at), mode, *_argv(inputs, out)], env=env,
                                 stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
                for (at, mode), out in zip(KILLS, outs)]  # at once: each pays its interpreter's start alone
    for (at, mode), out, child in zip(KILLS, outs, children):
        _, err = child.communicate(timeout=120)
        assert child.returncode == -signal.SIGKILL, err
        left = _outputs(out)
        # The kill came where it was meant to: ``at`` outputs in place (a "mid" one as its temporary).
        assert len([n for n in left if not n.startswith(".")]) == at, left
        assert len([n for n in left if n.startswith(".")]) == (mode == "mid"), left
    for out in outs:
        capsys.readouterr()
        assert main(_argv(inputs, out)) == 0, capsys.readouterr().err  # was exit 1: "exists and was not written by"
        assert _outputs(out) == reference, out.name  # the temporary removed, every output as a whole run's
        assert main(_argv(inputs, out)) == 0  # and the next rerun skips every input
        assert "0 written, 2 skipped" in capsys.readouterr().err


def test_an_intent_without_its_record_is_redone_and_a_file_without_either_is_refused(inputs, tmp_path):
    """The recovery, deterministically: the intent line the writer appends before an input's outputs."""
    out = tmp_path / "out"
    report = fill([inputs / "f0.npy"], out, method="scanline", format="both", progress=False)
    assert report.ok and len(report.written) == 1
    lines = [json.loads(line) for line in (out / LEDGER).read_text().splitlines()]
    assert [line.get("intent") for line in lines] == [True, None]  # the intent, then the record
    assert lines[0]["outputs"] == lines[1]["outputs"] == ["f0.png", "f0.npy"]
    # As a kill after the first output leaves it: the intent only, one output there (another's bytes).
    (out / LEDGER).write_text(json.dumps(lines[0]) + "\n")
    (out / "f0.npy").unlink()
    (out / "f0.png").write_bytes(b"half of a run")
    report = fill([inputs / "f0.npy"], out, method="scanline", format="both", progress=False)
    assert report.ok and len(report.written) == 1
    assert (out / "f0.png").read_bytes() != b"half of a run" and (out / "f0.npy").is_file()
    # An intent of another method does not let this one replace the file.
    (out / LEDGER).write_text(json.dumps({**lines[0], "recipe": {**lines[0]["recipe"], "method": "nearest"}}) + "\n")
    (out / "f0.npy").unlink()
    report = fill([inputs / "f0.npy"], out, method="scanline", format="both", progress=False)
    assert not report.ok and "was being made with method" in report.failed[0][1]
    # No line at all: a file of someone else's, refused as before.
    (out / LEDGER).write_text("")
    report = fill([inputs / "f0.npy"], out, method="scanline", format="both", progress=False)
    assert not report.ok and "was not written by inpaintenv fill" in report.failed[0][1]


def test_ledger_lines_of_another_shape_or_naming_files_outside_record_nothing(inputs, tmp_path):
    """A tampered ledger: outputs that are not paths (an unhashable one crashed the run with a TypeError),
    an intent naming files outside --out (never touched: only a job's own outputs are looked up)."""
    out = tmp_path / "out"
    victim = tmp_path / "victim.png"
    victim.write_bytes(b"the user's")
    assert fill([inputs / "f0.npy"], out, method="scanline", progress=False).ok
    record = json.loads((out / LEDGER).read_text().splitlines()[-1])
    (out / LEDGER).write_text("\n".join(json.dumps(line) for line in [
        {"outputs": [{}], "input": {}}, {"outputs": ["f0.png", 5], "input": {}},
        {**record, "intent": True, "outputs": ["../victim.png", str(victim), "f0.png"]}]) + "\n")
    report = fill([inputs / "f0.npy"], out, method="scanline", progress=False)
    assert report.ok and len(report.written) == 1  # the intent of f0.png's own recipe: redone
    assert victim.read_bytes() == b"the user's"
