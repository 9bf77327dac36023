"""export and score read and write through the safe file layer: a PNG bomb is refused
before it is decoded, a manifest that is a FIFO or nested JSON is one clear error, and
nothing of an export goes through a link planted at a temporary name."""

from __future__ import annotations

import os
import struct
import zlib

import cv2
import numpy as np
import pytest

from inpaintenv.cli import main
from inpaintenv.data import write_depth_png
from inpaintenv.exceptions import UnsafeFileError
from inpaintenv.submission import ManifestError, SubmissionError, export, layout, read_manifest, score


def png_header_only(width: int, height: int, bit_depth: int = 16, colour: int = 0) -> bytes:
    """A PNG that declares ``width x height`` and holds no pixels (what a bomb's first bytes look like)."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    ihdr = struct.pack(">IIBBBBB", width, height, bit_depth, colour, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"\0" * 64)) + \
        chunk(b"IEND", b"")


@pytest.fixture
def submitted(tmp_path, streets):
    """A two-frame export and predictions that keep the input and put 10 m in the holes."""
    manifest = export(tmp_path / "inputs", streets, "rect-v1", [0], n_frames=2, progress=False)
    for item in manifest.items:
        write_depth_png(tmp_path / "predictions" / item.input,
                        np.where(manifest.read_hole(item), 10.0, manifest.read_input(item)))
    return manifest, tmp_path / "predictions"


def test_a_png_bomb_is_refused_by_its_header_before_decoding(submitted, monkeypatch):
    manifest, predictions = submitted
    (predictions / manifest.items[0].input).write_bytes(png_header_only(20000, 20000))
    decoded = []
    real = cv2.imdecode
    monkeypatch.setattr(cv2, "imdecode", lambda buf, flags: decoded.append(len(buf)) or real(buf, flags))
    with pytest.raises(SubmissionError, match=r"declares 20000x20000, the input is 192x64 \(W x H\); not decoded"):
        score(manifest.path, predictions)
    bomb = len(png_header_only(20000, 20000))
    assert bomb not in decoded  # the other, valid prediction was decoded; the bomb never


def test_a_file_of_another_format_is_not_handed_to_the_decoder(submitted):
    manifest, predictions = submitted
    ok, tiff = cv2.imencode(".tiff", np.zeros((64, 192), np.uint16))
    assert ok
    (predictions / manifest.items[0].input).write_bytes(tiff.tobytes())
    with pytest.raises(SubmissionError, match="is not a readable PNG"):
        score(manifest.path, predictions)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="FIFOs are POSIX")
def test_a_fifo_manifest_is_refused_not_reported_missing(tmp_path):
    os.mkfifo(tmp_path / "k.json")
    with pytest.raises(UnsafeFileError, match="FIFO"):
        read_manifest(tmp_path / "k.json")


@pytest.mark.parametrize("text, message", [
    ("[" * 100_000 + "]" * 100_000, "nested deeper"),
    ('{"format": "inpaintenv-submission", "format_version": NaN}', "not valid JSON"),
], ids=["nested", "nan"])
def test_hostile_manifest_json_is_one_manifest_error(tmp_path, text, message, capsys):
    (tmp_path / "k.json").write_text(text)
    with pytest.raises(ManifestError, match=message):
        read_manifest(tmp_path / "k.json")
    argv = ["score", "--manifest", str(tmp_path / "k.json"), "--predictions", str(tmp_path), "--name", "x", "--out",
            str(tmp_path / "run"), "-q"]
    assert main(argv) == 1
    assert len(capsys.readouterr().err.strip().splitlines()) == 1


def test_an_export_never_writes_through_a_link_at_a_temporary_name(tmp_path, streets):
    """Links planted at the names earlier versions used for the kit's and the key's temporaries."""
    victim_dir = tmp_path / "victim"
    victim_dir.mkdir()
    victim = tmp_path / "victim.txt"
    victim.write_bytes(b"precious")
    (tmp_path / f".x.partial-{os.getpid()}").symlink_to(victim_dir)
    (tmp_path / f".x.key.json.partial-{os.getpid()}").symlink_to(victim)
    manifest = export(tmp_path / "x", streets, n_frames=2, progress=False)
    assert list(victim_dir.iterdir()) == [] and victim.read_bytes() == b"precious"
    assert not (tmp_path / "x").is_symlink() and not manifest.path.is_symlink()
    assert read_manifest(manifest.path).role == "score-key"


def test_the_kit_and_key_leave_no_temporary_behind(tmp_path, streets):
    export(tmp_path / "x", streets, n_frames=2, progress=False)
    export(tmp_path / "x", streets, n_frames=2, progress=False, overwrite=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x", "x.key.json"]


def test_read_inside_refuses_a_fifo_at_once(tmp_path):
    if not hasattr(os, "mkfifo"):
        pytest.skip("FIFOs are POSIX")
    os.mkfifo(tmp_path / "a.png")
    with pytest.raises(UnsafeFileError, match="FIFO"):
        layout.read_inside(tmp_path, "a.png", 1000)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="FIFOs are POSIX")
def test_export_names_a_fifo_manifest_in_out(tmp_path, streets):
    (tmp_path / "x").mkdir()
    os.mkfifo(tmp_path / "x" / "manifest.json")
    with pytest.raises(UnsafeFileError, match=r"manifest.json is a FIFO \(named pipe\)"):
        export(tmp_path / "x", streets, n_frames=2, progress=False, overwrite=True)


def test_a_name_that_is_not_utf8_is_shown_escaped(submitted):
    manifest, predictions = submitted
    first = predictions / manifest.items[0].input
    (first.parent / os.fsdecode(b"caf\xe9.png")).write_bytes(first.read_bytes())
    with pytest.raises(SubmissionError, match=r"caf\\xe9\.png") as caught:
        score(manifest.path, predictions)
    str(caught.value).encode("utf-8")  # printable to any UTF-8 stream, no surrogate left


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="FIFOs are POSIX")
def test_a_ground_truth_fifo_is_named_not_reported_missing(tmp_path):
    from inpaintenv.data import KittiDepth

    gt_file = tmp_path / "kitti" / "val" / "2011_09_26_drive_0002_sync" / "proj_depth" / "groundtruth" / "image_02" / \
        "0000000000.png"
    write_depth_png(gt_file, np.where(np.random.default_rng(0).random((32, 64)) < 0.5, 12.0, 0.0))
    m = export(tmp_path / "x", KittiDepth(tmp_path / "kitti", split="val", crop=None), progress=False)
    for item in m.items:
        write_depth_png(tmp_path / "p" / item.input, np.where(m.read_hole(item), 10.0, m.read_input(item)))
    gt_file.unlink()
    os.mkfifo(gt_file)
    with pytest.raises(UnsafeFileError, match=r"ground-truth file .* is a FIFO"):
        score(m.path, tmp_path / "p", kitti_root=tmp_path / "kitti")
