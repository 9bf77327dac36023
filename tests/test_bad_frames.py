"""``--on-bad-frame error|skip``: one unreadable PNG in a KITTI tree."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from inpaintenv.cli import main
from inpaintenv.data.io import write_depth_png

pytest.importorskip("estimators.classical")

DRIVE = "2011_09_26_drive_0001_sync"


@pytest.fixture
def kitti_tree(tmp_path):
    """A KITTI layout of 4 frames (one drive); returns ``(root, folder of the PNGs)``."""
    root = tmp_path / "kitti"
    folder = root / "train" / DRIVE / "proj_depth" / "groundtruth" / "image_02"
    folder.mkdir(parents=True)
    rng = np.random.default_rng(0)
    for k in range(4):
        depth = np.where(rng.random((375, 1242)) < 0.3, 5.0 + 20 * rng.random((375, 1242)), 0.0)
        write_depth_png(folder / f"{k:010d}.png", depth.astype(np.float32))
    return root, folder


def truncate(path):
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 3])


def bench(root, out, *extra):
    return ["benchmark", "--kitti-root", str(root), "-m", "constant", "--figure-frames", "1",
            "--out", str(out), "--quiet", *extra]


def test_benchmark_stops_on_a_corrupt_png_naming_it_and_leaves_no_empty_rows(kitti_tree, tmp_path, capsys):
    root, folder = kitti_tree
    truncate(folder / "0000000000.png")  # the first frame scored
    out = tmp_path / "out"
    assert main(bench(root, out)) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert str(folder / "0000000000.png") in err and "--on-bad-frame skip" in err
    assert [p for p in (out / "rows").glob("*.jsonl") if p.stat().st_size == 0] == []


def test_benchmark_skip_lists_the_frame_in_results_report_and_table(kitti_tree, tmp_path, capsys):
    root, folder = kitti_tree
    truncate(folder / "0000000002.png")
    out = tmp_path / "out"
    assert main(bench(root, out, "--on-bad-frame", "skip")) == 0
    printed = capsys.readouterr().out
    doc = json.loads((out / "results.json").read_text())
    assert [r["index"] for r in doc["rows"]] == [0, 1, 3]
    (skipped,) = doc["skipped_frames"]
    assert skipped["index"] == 2 and skipped["frame_id"] == f"{DRIVE}/image_02/0000000002"
    assert "cannot decode" in skipped["reason"] and str(folder / "0000000002.png") in skipped["reason"]
    for text in (printed, (out / "results.md").read_text()):
        assert "Unreadable frames left out: 1 (--on-bad-frame skip; not counted in frames or skipped):" in text
        assert f"- frame 2 ({DRIVE}/image_02/0000000002): cannot decode" in text
    # A rerun tries the frame again and still lists it: never silently dropped.
    assert main(bench(root, out, "--on-bad-frame", "skip")) == 0
    assert json.loads((out / "results.json").read_text())["skipped_frames"][0]["index"] == 2


def test_evaluate_8_bit_png_error_and_skip(kitti_tree, tmp_path, capsys):
    root, folder = kitti_tree
    cv2.imwrite(str(folder / "0000000001.png"), np.full((375, 1242), 7, np.uint8))
    argv = ["evaluate", "--kitti-root", str(root), "-m", "constant", "--quiet"]
    assert main(argv) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(folder / "0000000001.png") in err and "8-bit" in err
    assert main([*argv, "--on-bad-frame", "skip", "--out", str(tmp_path / "ev")]) == 0
    out = capsys.readouterr().out
    assert "| constant | rect-v1 | 3 |" in out and "- frame 1 (" in out and "8-bit" in out
    doc = json.loads((tmp_path / "ev" / "results.json").read_text())
    assert [r["index"] for r in doc["skipped_frames"]] == [1]
    assert "Unreadable frames left out: 1" in (tmp_path / "ev" / "table.md").read_text()


def test_evaluate_api_on_bad_frame(kitti_tree):
    from inpaintenv.data import KittiDepth
    from inpaintenv.exceptions import BadFrameError
    from inpaintenv.evaluate import evaluate
    from inpaintenv.report.results import EvaluationResult

    root, folder = kitti_tree
    truncate(folder / "0000000003.png")
    ds = KittiDepth(root)
    with pytest.raises(BadFrameError, match="0000000003.png"):
        evaluate(lambda x: np.nan_to_num(x, nan=1.0), ds, progress=False)
    res = evaluate(lambda x: np.nan_to_num(x, nan=1.0), ds, progress=False, on_bad_frame="skip")
    assert len(res.rows) == 3 and res.meta["skipped_frames"][0]["index"] == 3
    with pytest.raises(ValueError, match="on_bad_frame"):
        evaluate(lambda x: x, ds, progress=False, on_bad_frame="ignore")
    assert EvaluationResult.concat([res, res]).meta["skipped_frames"] == res.meta["skipped_frames"]


def _bomb(path, side=60000):
    """A small PNG declaring a ``side`` x ``side`` 16-bit frame (its payload: a zlib stream of zeros)."""
    import struct
    import zlib

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    ihdr = struct.pack(">IIBBBBB", side, side, 16, 0, 0, 0, 0)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(bytes(1 << 16)))
                     + chunk(b"IEND", b""))


@pytest.mark.parametrize("kind", ["bomb", "tiff"])
def test_png_bomb_and_tiff_named_png_are_bad_frames_that_skip_leaves_out(kitti_tree, tmp_path, capsys, kind):
    # The bomb gave a raw cv2.error that --on-bad-frame skip did not catch; the TIFF was scored.
    root, folder = kitti_tree
    bad = folder / "0000000002.png"
    if kind == "bomb":
        _bomb(bad)
        why = "declares 60000 x 60000"
    else:
        ok, buf = cv2.imencode(".tiff", np.full((375, 1242), 2560, np.uint16))
        bad.write_bytes(buf.tobytes())
        why = "is a TIFF file, not a PNG"
    argv = ["evaluate", "--kitti-root", str(root), "-m", "constant", "--quiet"]
    assert main(argv) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(bad) in err and why in err and "--on-bad-frame skip" in err
    assert main([*argv, "--on-bad-frame", "skip", "--out", str(tmp_path / "ev")]) == 0
    doc = json.loads((tmp_path / "ev" / "results.json").read_text())
    assert [r["index"] for r in doc["rows"]] == [0, 1, 3] and why in doc["skipped_frames"][0]["reason"]
    # info reads the same header check: the same file is refused with the same words.
    capsys.readouterr()
    assert main(["info", "--kitti-root", str(root)]) == 1
    assert why in capsys.readouterr().err


def test_benchmark_with_every_frame_skipped_reports_them_instead_of_list_index_out_of_range(kitti_tree, tmp_path, capsys):
    root, folder = kitti_tree
    for path in folder.glob("*.png"):
        truncate(path)
    out = tmp_path / "out"
    assert main(bench(root, out, "--on-bad-frame", "skip")) == 0, capsys.readouterr().err
    doc = json.loads((out / "results.json").read_text())
    assert doc["rows"] == [] and [r["index"] for r in doc["skipped_frames"]] == [0, 1, 2, 3]
    assert "list index out of range" not in capsys.readouterr().err
