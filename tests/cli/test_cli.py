"""The ``inpaintenv`` CLI, run in-process on tiny synthetic data and on the real KITTI slice."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from inpaintenv.cli import SUBCOMMANDS, build_parser, main
from inpaintenv.report.results import EvaluationResult

TINY = ["--n-frames", "3", "--frame-shape", "48", "120"]


def test_parser_has_subcommands():
    parser = build_parser()
    assert len(SUBCOMMANDS) >= 3
    for cmd in ("info", "evaluate", "show"):
        args = parser.parse_args([cmd, "--method", "nearest"] if cmd != "info" else [cmd])
        assert callable(args.func)


def test_info(capsys):
    assert main(["info", *TINY]) == 0
    out = capsys.readouterr().out
    assert "SyntheticStreets" in out and "valid_density" in out and "rect-v1" in out and "telea" in out


def test_info_json(capsys):
    assert main(["info", "--json", *TINY]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["frames"] == 3 and info["frame_shape"] == [48, 120]
    assert 0.0 < info["valid_density"] < 1.0


def test_evaluate_writes_json_csv_and_prints_table(tmp_path, capsys):
    out = tmp_path / "res"
    rc = main(["evaluate", "-m", "nearest", "-m", "constant", "--seed", "0", "--seed", "1",
               "--out", str(out), "--quiet", "--by-drive", *TINY])
    assert rc == 0
    text = capsys.readouterr().out
    assert text.startswith("| method |")
    assert "| nearest |" in text and "| constant |" in text
    res = EvaluationResult.from_json(out / "results.json")
    assert len(res.rows) == 2 * 2 * 3  # methods x seeds x frames
    assert res.methods == ["nearest", "constant"]
    assert res.meta["seeds"] == [0, 1] and "evaluate" in res.meta["command"]
    csv_rows = EvaluationResult.from_csv(out / "results.csv").rows
    assert [r["hole_rmse"] for r in csv_rows] == pytest.approx([r["hole_rmse"] for r in res.rows], nan_ok=True)
    assert (out / "table.md").read_text().startswith("| method |")
    # The table as CSV: 6 (seed, frame) pairs per method, so an interval (not n=1) per row.
    table_csv = (out / "table.csv").read_text().splitlines()
    assert table_csv[0].startswith("method,protocol,n_frames,n_skipped_hole,hole_rmse,hole_rmse_low")
    assert len(table_csv) == 3


def test_evaluate_unknown_method_is_one_line_error(capsys):
    assert main(["evaluate", "-m", "telee", *TINY]) == 1
    err = capsys.readouterr().err
    assert "unknown method 'telee'" in err and "telea" in err and "Traceback" not in err


def test_evaluate_bad_protocol_and_n_frames(capsys):
    assert main(["evaluate", "-m", "nearest", "--protocol", "nope", *TINY]) == 1
    assert "unknown occlusion protocol" in capsys.readouterr().err
    assert main(["evaluate", "-m", "nearest", "--n-frames", "0"]) == 1
    assert "--n-frames" in capsys.readouterr().err


def test_show_writes_panel(tmp_path, capsys):
    out = tmp_path / "sub" / "panel.png"
    assert main(["show", "-m", "nearest", "--index", "1", "--seed", "2", "--out", str(out), *TINY]) == 0
    printed = capsys.readouterr().out
    assert "hole RMSE" in printed and "all RMSE" in printed
    img = cv2.imread(str(out))
    assert img is not None and img.dtype == np.uint8 and img.shape[1] == 120
    assert img.shape[0] > 5 * 48


def test_show_without_method_and_bad_index(tmp_path, capsys):
    assert main(["show", "--out", str(tmp_path / "p.png"), *TINY]) == 0
    assert (tmp_path / "p.png").exists()
    assert main(["show", "--index", "9", "--out", str(tmp_path / "q.png"), *TINY]) == 1
    assert "out of range" in capsys.readouterr().err


@pytest.mark.parametrize(
    "argv, message",
    [
        (["evaluate", "-m", "constant", "--max-depth", "nan"], "--max-depth must be a finite positive number of metres, got nan"),
        (["evaluate", "-m", "constant", "--max-depth", "inf"], "--max-depth must be a finite positive number"),
        (["evaluate", "-m", "constant", "--seed", "0", "--seed", "0"], r"--seed must be distinct non-negative integers, got [0, 0]"),
        (["evaluate", "-m", "constant", "--seed", "-1"], "--seed must be distinct non-negative integers"),
        (["show", "--max-depth", "nan"], "--max-depth must be a finite positive number of metres, got nan"),
        (["show", "--seed", "-1"], "--seed must be a non-negative integer, got -1"),
    ],
)
def test_bad_numbers_are_one_line_errors(tmp_path, capsys, argv, message):
    # NaN max depth used to print NaN/inf PSNR and exit 0; repeated seeds scored frames twice.
    if argv[0] == "show":
        argv = [*argv, "--out", str(tmp_path / "p.png")]
    assert main([*argv, *TINY, "-q"]) == 1
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not (tmp_path / "p.png").exists()


@pytest.mark.parametrize("out", ["panel", "panel.jpg", "."])
def test_show_out_must_be_a_png_file(tmp_path, capsys, monkeypatch, out):
    # Without a .png suffix OpenCV failed with its own traceback ("could not find a writer").
    monkeypatch.chdir(tmp_path)
    assert main(["show", "--out", out, *TINY]) == 1
    err = capsys.readouterr().err
    assert f"--out must be a .png file, got '{out}'" in err and "Traceback" not in err
    (tmp_path / "dir.png").mkdir()
    assert main(["show", "--out", "dir.png", *TINY]) == 1
    assert "--out must be a .png file" in capsys.readouterr().err


@pytest.mark.kitti
def test_cli_on_real_kitti(kitti_root, kitti_layout, tmp_path, capsys):
    root = str(kitti_root)
    assert main(["info", "--kitti-root", root, "--split", "train", "--json", "--sample", "2"]) == 0
    info = json.loads(capsys.readouterr().out)
    on_disk = kitti_layout("train")
    assert info["frames"] == sum(on_disk.values()) and info["drives"] == len(on_disk)
    rc = main(["evaluate", "-m", "nearest", "--kitti-root", root, "--split", "val", "-q",
               "--out", str(tmp_path)])
    assert rc == 0
    res = EvaluationResult.from_json(tmp_path / "results.json")
    assert len(res.rows) == 1 and res.rows[0]["hole_count"] > 0
    assert res.rows[0]["frame_id"].startswith("2011_10_03_drive_9101_sync")
    assert main(["show", "-m", "nearest", "--kitti-root", root, "--split", "val",
                 "--out", str(tmp_path / "k.png")]) == 0
    assert cv2.imread(str(tmp_path / "k.png")).shape[1] == 1216


def test_info_lists_the_input_kinds_and_scan_only_protocols(capsys):
    assert main(["info", *TINY]) == 0
    text = capsys.readouterr().out
    assert "input kinds: map (" in text and "; scan (" in text
    assert "densify-v1 (scan only)" in text and "rect-v1" in text and "rect-v1 (" not in text
    assert main(["info", "--json", *TINY]) == 0
    info = json.loads(capsys.readouterr().out)
    assert {"map", "scan", "scan-rings16-v1", "scan-points25-v1"} <= set(info["input_kinds"])
    scans = [k for k in info["input_kinds"] if k != "map"]
    assert info["protocols"]["densify-v1"] == scans and info["protocols"]["rect-v1"] == ["map", *scans]
