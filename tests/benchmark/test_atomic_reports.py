"""Report files are written whole or not at all: a full disk during a rerun
leaves the previous report intact and names the file it could not write."""

from __future__ import annotations

import errno
import pathlib

import numpy as np
import pytest

from inpaintenv.benchmark import run_benchmark, write_report
from inpaintenv.benchmark.figures import plot_error_vs_hole_size
from inpaintenv import files
from inpaintenv.files import writing as files_writing

REPORT = ("results.json", "results.csv", "table.csv", "by_drive.csv", "results.md")


def ten(x):
    return np.where(np.isnan(x), 10.0, x)


def twenty(x):
    return np.where(np.isnan(x), 20.0, x)


def snapshot(out):
    return {p.relative_to(out).as_posix(): p.read_bytes() for p in out.rglob("*") if p.is_file()}


@pytest.fixture
def reported(small_gt, tmp_path):
    out = tmp_path / "run"
    result = run_benchmark({"ten": ten}, small_gt, out_dir=out, progress=False)
    write_report(result, out)
    rerun = run_benchmark({"ten": ten, "twenty": twenty}, small_gt, out_dir=out, progress=False)
    return out, rerun


def no_space(*args, **kwargs):
    raise OSError(errno.ENOSPC, "No space left on device")


def test_a_write_that_fails_midway_leaves_the_old_report(reported, monkeypatch):
    out, rerun = reported
    before = snapshot(out)
    real = pathlib.Path.write_text

    def half_then_full_disk(self, data, *args, **kwargs):
        real(self, data[: len(data) // 2], *args, **kwargs)  # what a full disk leaves
        no_space()

    monkeypatch.setattr(pathlib.Path, "write_text", half_then_full_disk)
    with pytest.raises(OSError, match=f"cannot write {out / 'results.json'}: No space left on device"):
        write_report(rerun, out)
    monkeypatch.undo()
    after = snapshot(out)
    assert {k: v for k, v in after.items() if k in REPORT} == {k: v for k, v in before.items() if k in REPORT}
    assert not [p for p in out.rglob("*") if p.name.startswith(files.TEMP_PREFIX)]  # no temporary file left


@pytest.mark.parametrize("failing", [0, 1, 4])
def test_a_full_disk_at_any_report_file_names_it_and_keeps_it(reported, monkeypatch, failing):
    out, rerun = reported
    before = snapshot(out)
    calls = []
    real = files_writing.os.fsync

    def fsync(fd):  # the disk fills when the data reach it
        calls.append(fd)
        if len(calls) > failing:
            no_space()
        real(fd)

    monkeypatch.setattr(files_writing.os, "fsync", fsync)
    with pytest.raises(OSError, match=f"cannot write {out / REPORT[failing]}: No space left on device"):
        write_report(rerun, out)
    assert snapshot(out)[REPORT[failing]] == before[REPORT[failing]]


def test_a_figure_that_cannot_be_written_keeps_the_old_one(reported, monkeypatch):
    out, rerun = reported
    path = out / "figures" / "error_vs_hole_size.png"
    plot_error_vs_hole_size(rerun, path)
    old = path.read_bytes()
    monkeypatch.setattr(files_writing.os, "fsync", no_space)
    with pytest.raises(OSError, match=f"cannot write {path}: No space left on device"):
        plot_error_vs_hole_size(rerun, path)
    assert path.read_bytes() == old
