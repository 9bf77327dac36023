"""The safe file layer: regular files only, bounded reads and JSON, writes never through a link."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from inpaintenv import files
from inpaintenv.exceptions import FileTooLargeError, JSONFileError, UnsafeFileError


def test_a_fifo_is_refused_at_once_not_waited_on(tmp_path):
    fifo = tmp_path / "a.png"
    os.mkfifo(fifo)
    with pytest.raises(UnsafeFileError, match="a FIFO"):
        files.read_bytes(fifo, "depth PNG")
    with pytest.raises(UnsafeFileError, match="FIFO"):
        files.read_json(fifo, "config")


def test_a_missing_file_and_a_folder_are_named(tmp_path):
    with pytest.raises(FileNotFoundError, match="config not found"):
        files.read_bytes(tmp_path / "none.json", "config")
    with pytest.raises(IsADirectoryError, match="is a folder"):
        files.read_bytes(tmp_path, "config")


def test_size_is_checked_before_reading(tmp_path):
    big = tmp_path / "big.bin"
    with open(big, "wb") as f:
        f.truncate(10_000_000)  # sparse: no data written
    with pytest.raises(FileTooLargeError, match="10,000,000 bytes, more than the 1,000"):
        files.read_bytes(big, "scan", limit=1000)


def test_a_link_inside_an_owned_folder_is_not_followed(tmp_path):
    target = tmp_path / "victim.json"
    target.write_text('{"a": 1}')
    link = tmp_path / "state.json"
    link.symlink_to(target)
    assert files.read_json(link, "state") == {"a": 1}  # inputs may be links
    with pytest.raises(UnsafeFileError, match="symbolic link"):
        files.read_json(link, "state", follow_links=False)


def test_deeply_nested_json_is_one_clear_error(tmp_path):
    deep = tmp_path / "config.json"
    deep.write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(JSONFileError, match="nested deeper"):
        files.read_json(deep, "checkpoint config")
    with pytest.raises(JSONFileError, match="nested deeper than the 3"):
        files.loads_json('{"a": {"b": {"c": {}}}}', max_depth=3)
    with pytest.raises(JSONFileError, match="not valid JSON"):
        files.loads_json("{", "x")
    with pytest.raises(JSONFileError, match="not valid JSON"):
        files.loads_json('{"q": NaN}', "calibration", allow_nan=False)
    assert files.loads_json('{"q": 1.5}', allow_nan=False) == {"q": 1.5}


def test_an_atomic_write_replaces_a_planted_link_and_never_writes_through_it(tmp_path):
    victim = tmp_path / "victim"
    victim.write_text("keep me")
    out = tmp_path / "out"
    out.mkdir()
    (out / "report.json").symlink_to(victim)
    files.write_json(out / "report.json", {"ok": True})
    assert victim.read_text() == "keep me"
    assert not (out / "report.json").is_symlink()
    assert json.loads((out / "report.json").read_text()) == {"ok": True}
    assert [p.name for p in out.iterdir()] == ["report.json"]  # no temporary left


def test_temporary_names_are_unpredictable_and_short(tmp_path):
    seen = []
    long_name = "x" * 240 + ".png"  # the target's name may use almost all of NAME_MAX
    files.write_atomic(tmp_path / long_name, lambda tmp: (seen.append(tmp.name), tmp.write_bytes(b"1")))
    files.write_atomic(tmp_path / long_name, lambda tmp: (seen.append(tmp.name), tmp.write_bytes(b"2")))
    assert (tmp_path / long_name).read_bytes() == b"2"
    assert all(n.startswith(f"{files.TEMP_PREFIX}{os.getpid()}-") and len(n) < 64 for n in seen)
    assert seen[0] != seen[1]


def test_append_and_lock_refuse_links_and_never_truncate(tmp_path):
    victim = tmp_path / "victim"
    victim.write_text("keep me")
    (tmp_path / "rows.jsonl").symlink_to(victim)
    (tmp_path / "run.lock").symlink_to(victim)
    with pytest.raises(UnsafeFileError, match="symbolic link"):
        files.append_text(tmp_path / "rows.jsonl", "{}\n", "row file")
    with pytest.raises(UnsafeFileError, match="symbolic link"):
        files.open_lock(tmp_path / "run.lock")
    assert victim.read_text() == "keep me"
    files.append_text(tmp_path / "own.jsonl", "a\n")
    files.append_text(tmp_path / "own.jsonl", "b\n")
    assert (tmp_path / "own.jsonl").read_text() == "a\nb\n"
    fd = files.open_lock(tmp_path / "own.jsonl")
    os.close(fd)
    assert (tmp_path / "own.jsonl").read_text() == "a\nb\n"  # a lock is opened, not truncated


def test_stale_temporaries_of_a_dead_writer_are_removed_and_nothing_else(tmp_path):
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    pid = int(dead.stdout)
    stale = tmp_path / f"{files.TEMP_PREFIX}{pid}-abcd.png"
    stale.write_bytes(b"half")
    live = tmp_path / f"{files.TEMP_PREFIX}{os.getpid()}-abcd.png"
    live.write_bytes(b"being written")
    mine = tmp_path / "x.png"
    mine.write_bytes(b"user")
    assert files.remove_stale_temporaries(tmp_path) == [stale]
    assert live.exists() and mine.exists()


#: Temp-looking names whose pid is not one: a superscript digit (a digit to str.isdigit, not to
#: int), an Arabic-Indic digit, 23 digits (os.kill overflows), 0, and a number past a pid_t.
UNPARSEABLE_PIDS = ["\u00b2", "\u0663", "1" * 23, "0", str(2**31), "", "+12", " 12"]


def test_a_temp_looking_name_whose_pid_does_not_parse_is_left_alone(tmp_path):
    from inpaintenv.files.processes import parse_pid, writer_gone

    names = [f"{files.TEMP_PREFIX}{pid}-abc.png" for pid in UNPARSEABLE_PIDS]
    for name in names:
        (tmp_path / name).write_bytes(b"not ours")
    assert files.remove_stale_temporaries(tmp_path) == []  # was ValueError / OverflowError
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(names)
    assert [parse_pid(p) for p in UNPARSEABLE_PIDS] == [None] * len(UNPARSEABLE_PIDS)
    assert parse_pid(True) is None and parse_pid(10**23) is None and parse_pid("4194304") == 4194304
    assert not writer_gone("1" * 23) and not writer_gone(str(os.getpid()))


def test_a_folder_link_inside_the_owned_folder_is_never_written_through(tmp_path):
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    out = tmp_path / "out"
    (out / "a").mkdir(parents=True)
    (out / "a" / "sub").symlink_to(elsewhere, target_is_directory=True)
    with pytest.raises(UnsafeFileError, match=r"out/a/sub is a symbolic link"):
        files.write_bytes_atomic(out / "a" / "sub" / "deep" / "x.png", b"1", "depth file", within=out)
    assert list(elsewhere.iterdir()) == []  # nothing made there, not even a folder
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    stale = elsewhere / f"{files.TEMP_PREFIX}{int(dead.stdout)}-abcd.png"
    stale.write_bytes(b"not ours to remove")
    assert files.remove_stale_temporaries(out / "a" / "sub", within=out) == []
    # Missing folders are made inside; a folder given as the owned root itself may be a link (the user's choice).
    files.write_bytes_atomic(out / "b" / "c" / "x.png", b"2", within=out)
    assert (out / "b" / "c" / "x.png").read_bytes() == b"2"
    (tmp_path / "link_out").symlink_to(out, target_is_directory=True)
    files.write_bytes_atomic(tmp_path / "link_out" / "y.png", b"3", within=tmp_path / "link_out")
    assert (out / "y.png").read_bytes() == b"3"
    (out / "file").write_bytes(b"")
    with pytest.raises(NotADirectoryError, match="not a folder"):
        files.write_bytes_atomic(out / "file" / "z.png", b"4", within=out)
    with pytest.raises(ValueError, match="not inside"):
        files.write_bytes_atomic(tmp_path / "z.png", b"5", within=out)
    assert stale.exists()


def test_frame_size_limit_is_one_place():
    from inpaintenv import conventions

    assert conventions.MAX_FRAME_PIXELS is files.MAX_FRAME_PIXELS
    files.check_frame_pixels(375, 1242, "frame")
    with pytest.raises(FileTooLargeError, match="20000 x 20000"):
        files.check_frame_pixels(20000, 20000, "mask PNG m.png")
