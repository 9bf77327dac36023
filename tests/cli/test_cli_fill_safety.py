"""``inpaintenv fill`` against hostile files and careless reruns.

Planted links and predictable temporaries, long names, outputs that other methods,
inputs or users made (7), FIFOs (14), bad arrays in ``fill_depth`` (17), hints (20), warnings and
built-in functions as methods (25), two runs into one ``--out`` (27), a model that predicts 303 m (10).
"""

from __future__ import annotations

import fcntl
import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from inpaintenv.files.lock import LOCK_FILE
from inpaintenv.cli import main
from inpaintenv.data import SyntheticStreets, read_depth_file, write_depth_png
from inpaintenv.exceptions import InvalidInputError, InvalidTypeError
from inpaintenv.filling import fill, fill_depth
from inpaintenv.filling.ledger import LEDGER

SHAPE = (48, 80)


def frame(seed: int = 0) -> np.ndarray:
    return np.asarray(SyntheticStreets(n=1, frame_shape=SHAPE, kind="velodyne_raw", seed=seed)[0], np.float32)


def holed(seed: int = 0) -> np.ndarray:
    x = frame(seed)
    x[10:30, 20:50] = np.nan
    return x


def run(*args: str) -> int:
    return main(["fill", *args, "-q"])


def test_no_temporary_name_can_be_planted_and_no_output_link_is_written_through(tmp_path):
    victim = tmp_path / "victim"
    victim.write_bytes(b"precious")
    out = tmp_path / "out"
    out.mkdir()
    np.save(tmp_path / "a.npy", holed())
    # The former temporary names, predictable from the pid: a link there was written through, a folder
    # there failed the file.
    (out / f".a.png.tmp-{os.getpid()}.png").symlink_to(victim)
    (out / f".a_low.png.tmp-{os.getpid()}.png").mkdir()
    assert fill([tmp_path / "a.npy"], out, method="scanline", progress=False, confidence=0.9).ok
    assert victim.read_bytes() == b"precious"
    # A link planted at the output itself is replaced by the file (with --overwrite), never written through.
    (out / "a.png").unlink()
    (out / "a.png").symlink_to(victim)
    assert run(str(tmp_path / "a.npy"), "-m", "scanline", "--overwrite", "--out", str(out)) == 0
    assert victim.read_bytes() == b"precious"
    assert not (out / "a.png").is_symlink() and (read_depth_file(out / "a.png") > 0).any()


@pytest.mark.parametrize("pid", ["\u00b2", "1" * 23])
def test_a_temp_looking_name_whose_pid_does_not_parse_is_left_alone_and_fill_runs(tmp_path, capsys, pid):
    """A superscript digit (ValueError) or 23 digits (OverflowError) crashed every later fill."""
    out = tmp_path / "out"
    out.mkdir()
    odd = out / f".inpaintenv-tmp-{pid}-abc.png"
    odd.write_bytes(b"not ours")
    np.save(tmp_path / "a.npy", holed())
    assert run(str(tmp_path / "a.npy"), "-m", "scanline", "--out", str(out)) == 0
    assert "Traceback" not in capsys.readouterr().err
    assert odd.read_bytes() == b"not ours" and (out / "a.png").is_file()


def test_a_name_of_250_bytes_is_written(tmp_path, capsys):
    name = "f" * 246 + ".npy"  # the output a.png is 250 bytes; the former hidden temporary name was over 255
    np.save(tmp_path / name, holed())
    assert run(str(tmp_path / name), "-m", "scanline", "--out", str(tmp_path / "out")) == 0
    assert "1 written" in capsys.readouterr().err
    assert (tmp_path / "out" / ("f" * 246 + ".png")).is_file()


def test_a_fifo_named_like_a_depth_file_is_one_line_and_the_run_goes_on(tmp_path):
    (tmp_path / "in").mkdir()
    os.mkfifo(tmp_path / "in" / "a.png")
    os.mkfifo(tmp_path / "b.npy")
    np.save(tmp_path / "in" / "c.npy", holed())
    cmd = [sys.executable, "-m", "inpaintenv.cli", "fill", str(tmp_path / "in"), str(tmp_path / "b.npy"),
           "-m", "scanline", "--out", str(tmp_path / "out"), "-q"]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=120)  # a hang is a failure, not a wait
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 1, done.stderr
    assert any("a.png is a FIFO (named pipe), not a regular file" in line for line in lines), done.stderr
    assert any("b.npy is a FIFO (named pipe), not a regular file" in line for line in lines), done.stderr
    assert lines[-1] == "fill: 1 written, 0 skipped, 2 failed"
    assert (tmp_path / "out" / "c.png").is_file()


@pytest.mark.parametrize("depth, mask, error, words", [
    (np.full((16, 16), None), None, InvalidTypeError, "dtype object"),
    (np.full((16, 16), "a"), None, InvalidTypeError, "dtype <U1"),
    (None, None, InvalidTypeError, "dtype object"),
    (np.full((16, 16), 5, np.int64), np.eye(16, dtype=bool), InvalidTypeError, "integer dtype"),
    (np.ones((16, 16), bool), np.eye(16, dtype=bool), InvalidTypeError, "boolean"),
    (np.full((16, 16), 5.0), np.eye(8, dtype=bool), InvalidInputError, "shape (16, 16), got (8, 8)"),
    (np.full((16, 16), 5.0), np.eye(16, dtype=bool)[None], InvalidInputError, "got (1, 16, 16)"),
    (np.full((16, 16), 5.0), np.full((16, 16), None), InvalidTypeError, "booleans or numbers"),
    (np.full((2, 16, 16), 5.0), None, InvalidInputError, "2-D"),
])
def test_fill_depth_refuses_bad_arrays_with_one_clear_error(depth, mask, error, words):
    with pytest.raises(error) as info:
        fill_depth("nearest", depth, mask)
    assert words in str(info.value)


def test_fill_depth_takes_a_mask_of_numbers():
    d = np.full((16, 16), 5.0)
    out = fill_depth("nearest", d, np.eye(16, dtype=np.uint8))
    assert out.dtype == np.float64 and (out == 5.0).all()


class _LeavesHoles:
    """A method named scanline that leaves every pixel to fill at 0 m."""

    name = "scanline"

    def predict(self, X):
        return np.nan_to_num(np.asarray(X, np.float32), nan=0.0)


def test_a_method_that_leaves_pixels_unfilled_is_not_suggested_again(tmp_path):
    np.save(tmp_path / "a.npy", holed())
    lines: list[str] = []
    report = fill([tmp_path / "a.npy"], tmp_path / "out", method=_LeavesHoles(), progress=False, log=lines.append)
    assert not report.ok and len(lines) == 1
    assert "left 600 of the 600 pixels to fill at 0 m" in lines[0]
    assert "--method scanline" not in lines[0] and "--method nearest" in lines[0]


def test_a_frame_without_any_measurement_says_so(tmp_path):
    np.save(tmp_path / "a.npy", np.full(SHAPE, np.nan, np.float32))
    lines: list[str] = []
    assert not fill([tmp_path / "a.npy"], tmp_path / "out", method="nearest", progress=False, log=lines.append).ok
    assert "no measurement outside the pixels to fill" in lines[0]


def test_builtin_functions_as_methods_are_refused_in_one_line(tmp_path, capsys):
    np.save(tmp_path / "a.npy", holed())
    for name in ("os:system", "os:environ"):
        assert run(str(tmp_path / "a.npy"), "-m", name, "--out", str(tmp_path / "out")) != 0
        err = capsys.readouterr().err
        assert "not a depth method" in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists()


class _HugeStd:
    """A method whose std is the largest float32: its interval overflows float32."""

    def predict(self, X, return_std=False):
        pred = np.nan_to_num(np.asarray(X, np.float32), nan=10.0)
        return (pred, np.full(pred.shape, 3e38, np.float32)) if return_std else pred


def test_fill_prints_no_numpy_warning(tmp_path):
    np.save(tmp_path / "a.npy", holed())
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        report = fill([tmp_path / "a.npy"], tmp_path / "out", method=_HugeStd(), confidence=0.9, format="both",
                      progress=False)
    assert report.ok, report.failed
    assert read_depth_file(tmp_path / "out" / "a_high.npy").max() <= 65535 / 256


class _Diverged:
    """A briefly trained model: 303 m on the frame whose first measured row is its marker."""

    def predict(self, X):
        out = np.nan_to_num(np.asarray(X, np.float32), nan=10.0)
        out[X[:, 0, 0] == 7.0] = 303.0
        return out


def test_one_frame_predicted_at_303_m_is_one_line_and_the_others_are_written(tmp_path):
    (tmp_path / "in").mkdir()
    for k in range(3):
        x = holed(k)
        x[0, 0] = 7.0 if k == 1 else 5.0
        np.save(tmp_path / "in" / f"{k}.npy", x)
    lines: list[str] = []
    report = fill([tmp_path / "in"], tmp_path / "out", method=_Diverged(), progress=False, log=lines.append)
    assert [p.name for p, _ in report.failed] == ["1.npy"] and len(lines) == 1
    assert "303 m" in lines[0] and lines[0].startswith(str(tmp_path / "in" / "1.npy"))
    assert sorted(p.name for p in (tmp_path / "out").glob("*.png")) == ["0.png", "2.png"]


def test_a_second_run_into_the_same_out_is_refused_in_one_line(tmp_path, capsys):
    np.save(tmp_path / "a.npy", holed())
    (tmp_path / "out").mkdir()
    fd = os.open(tmp_path / "out" / LOCK_FILE, os.O_RDWR | os.O_CREAT)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)  # another run holds --out
        os.write(fd, b'{"pid": 1, "host": "elsewhere", "started": "now"}')
        rc = run(str(tmp_path / "a.npy"), "-m", "scanline", "--out", str(tmp_path / "out"))
    finally:
        os.close(fd)
    err = capsys.readouterr().err
    assert rc != 0 and "in use by another run" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "out" / "a.png").exists()
    assert run(str(tmp_path / "a.npy"), "-m", "scanline", "--out", str(tmp_path / "out")) == 0  # released: goes on


def test_an_output_the_user_put_there_is_not_overwritten_when_its_sibling_is_missing(tmp_path, capsys):
    np.save(tmp_path / "a.npy", holed())
    (tmp_path / "out").mkdir()
    write_depth_png(tmp_path / "out" / "a.png", frame(9))  # the user's own file, a.npy missing
    mine = (tmp_path / "out" / "a.png").read_bytes()
    assert run(str(tmp_path / "a.npy"), "-m", "scanline", "--format", "both", "--out", str(tmp_path / "out")) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and f"{tmp_path / 'out' / 'a.png'} exists and was not written by inpaintenv fill" in err[0]
    assert "--overwrite" in err[0] and err[1] == "fill: 0 written, 0 skipped, 1 failed"
    assert (tmp_path / "out" / "a.png").read_bytes() == mine and not (tmp_path / "out" / "a.npy").exists()
    assert run(str(tmp_path / "a.npy"), "-m", "scanline", "--format", "both", "--overwrite",
               "--out", str(tmp_path / "out")) == 0
    assert (tmp_path / "out" / "a.npy").is_file() and (tmp_path / "out" / "a.png").read_bytes() != mine


def test_outputs_of_another_method_or_input_are_refused_naming_what_differs(tmp_path, capsys):
    np.save(tmp_path / "a.npy", holed(0))
    out = str(tmp_path / "out")
    assert run(str(tmp_path / "a.npy"), "-m", "scanline", "--out", out) == 0
    capsys.readouterr()
    assert run(str(tmp_path / "a.npy"), "-m", "scanline", "--out", out) == 0  # the same command: resumed
    assert "0 written, 1 skipped" in capsys.readouterr().err
    assert run(str(tmp_path / "a.npy"), "-m", "nearest", "--out", out) == 1
    err = capsys.readouterr().err
    assert 'exists and was made with method "scanline" (now "nearest")' in err
    (tmp_path / "other").mkdir()
    np.save(tmp_path / "other" / "a.npy", holed(1))
    assert run(str(tmp_path / "other" / "a.npy"), "-m", "scanline", "--out", out) == 1
    assert f"from another input ({tmp_path / 'a.npy'})" in capsys.readouterr().err
    np.save(tmp_path / "a.npy", holed(2))  # the input changed since
    os.utime(tmp_path / "a.npy", ns=(1, 1))
    assert run(str(tmp_path / "a.npy"), "-m", "scanline", "--out", out) == 1
    assert "from an earlier version of its input" in capsys.readouterr().err
    assert run(str(tmp_path / "a.npy"), "-m", "scanline", "--box", "0,0,4,4", "--overwrite", "--out", out) == 0
    capsys.readouterr()
    assert run(str(tmp_path / "a.npy"), "-m", "scanline", "--out", out) == 1  # the boxes are part of what made it
    assert 'with boxes [[0, 0, 4, 4]] (now [])' in capsys.readouterr().err
    assert (tmp_path / "out" / LEDGER).is_file()


def test_a_folder_of_out_that_links_elsewhere_is_refused_in_one_line_and_the_run_goes_on(tmp_path, capsys):
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    for sub in ("sub", "ok"):
        (tmp_path / "in" / sub).mkdir(parents=True)
        np.save(tmp_path / "in" / sub / "a.npy", holed())
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "sub").symlink_to(elsewhere, target_is_directory=True)
    assert run(str(tmp_path / "in"), "-m", "scanline", "--out", str(tmp_path / "out")) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and f"{tmp_path / 'out' / 'sub'} is a symbolic link" in err[0], err
    assert err[1] == "fill: 1 written, 0 skipped, 1 failed"
    assert list(elsewhere.iterdir()) == [] and (tmp_path / "out" / "ok" / "a.png").is_file()


def test_size_past_the_frame_limit_is_a_usage_error_naming_the_limit(tmp_path, capsys):
    from inpaintenv.files import MAX_FRAME_PIXELS

    with pytest.raises(SystemExit) as info:
        run(str(tmp_path / "s.bin"), "--calib", str(tmp_path), "--size", "32768x32768", "--out", str(tmp_path / "o"))
    err = capsys.readouterr().err
    assert info.value.code == 2 and f"{MAX_FRAME_PIXELS:,}" in err and "Traceback" not in err


def test_a_checkpoint_folder_with_a_fifo_config_names_the_fifo(tmp_path, capsys):
    (tmp_path / "model").mkdir()
    (tmp_path / "model" / "model.safetensors").write_bytes(b"")
    os.mkfifo(tmp_path / "model" / "config.json")
    np.save(tmp_path / "a.npy", holed())
    assert run(str(tmp_path / "a.npy"), "--checkpoint", str(tmp_path / "model"), "--out", str(tmp_path / "o")) == 1
    err = capsys.readouterr().err
    assert "config.json is a FIFO (named pipe), not a regular file" in err and len(err.strip().splitlines()) == 1


def test_messages_naming_a_file_that_is_not_utf8_print_on_a_strict_stream(tmp_path):
    bad = os.fsencode(tmp_path) + b"/caf\xe9.png"
    with open(bad, "wb") as f:
        f.write(b"not a png")
    # A strict ASCII stderr, as an embedding program or a capture sets it (Python's own escapes for stderr).
    script = ("import io, sys; from inpaintenv.cli import main; "
              "sys.stderr = io.TextIOWrapper(sys.stderr.buffer, encoding='ascii', errors='strict'); "
              "sys.exit(main(sys.argv[1:]))")
    args = [os.fsdecode(bad), "-m", "scanline", "-q", "--out", str(tmp_path / "out")]
    for more in ([], ["--holes", os.fsdecode(os.fsencode(tmp_path) + b"/mask\xe9.png")]):
        done = subprocess.run([sys.executable, "-c", script, "fill", *args, *more], capture_output=True,
                              env={**os.environ, "PYTHONIOENCODING": "ascii"}, timeout=120)
        err = done.stderr.decode("ascii")
        assert done.returncode == 1 and "Traceback" not in err, err
        assert "\\udce9.png" in err.splitlines()[0], err
