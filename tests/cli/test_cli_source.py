"""Which data a CLI command scores: ``--kitti-root``, ``$INPAINTENV_KITTI_ROOT`` or the built-in
synthetic streets, and the options refused when they do not apply."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from inpaintenv.cli import main
from inpaintenv.data import write_depth_png

TINY = ["--n-frames", "2", "--frame-shape", "32", "96"]


@pytest.fixture(scope="module")
def tiny_kitti(tmp_path_factory) -> Path:
    """Two train frames and one val frame in the official layout, at KITTI's raw size."""
    root = tmp_path_factory.mktemp("kitti")
    rng = np.random.default_rng(0)
    rows = np.linspace(40.0, 5.0, 376)[:, None] + np.zeros((1, 1241))
    for split, drive, n in (("train", "2011_09_26_drive_0001_sync", 2), ("val", "2011_10_03_drive_0047_sync", 1)):
        for i in range(n):
            depth = np.where(rng.random(rows.shape) < 0.3, rows, 0.0)
            write_depth_png(root / split / drive / "proj_depth" / "groundtruth" / "image_02" / f"{i:010d}.png", depth)
    return root


def info_json(argv: list[str], capsys) -> dict:
    assert main(["info", "--json", "--sample", "1", *argv]) == 0
    return json.loads(capsys.readouterr().out)


def test_the_variable_stands_for_kitti_root(tiny_kitti, monkeypatch, capsys):
    # The README offers the variable as the alternative to --kitti-root; the CLI ignored it.
    monkeypatch.setenv("INPAINTENV_KITTI_ROOT", str(tiny_kitti))
    info = info_json(["--split", "val"], capsys)
    assert info["source"] == "KittiDepth" and info["split"] == "val" and info["frames"] == 1
    assert info_json([], capsys)["split"] == "train"  # KITTI's default split, as with --kitti-root
    assert info_json(["--synthetic", *TINY], capsys)["source"] == "SyntheticStreets"


def test_benchmark_and_evaluate_score_kitti_from_the_variable(tiny_kitti, monkeypatch, capsys, tmp_path):
    # The command: `INPAINTENV_KITTI_ROOT=<root> inpaintenv benchmark --split val -m scanline`.
    monkeypatch.setenv("INPAINTENV_KITTI_ROOT", str(tiny_kitti))
    assert main(["benchmark", "--split", "val", "-m", "scanline", "--figure-frames", "0", "--out",
                 str(tmp_path / "b")]) == 0
    err = capsys.readouterr().err
    assert f"data: KITTI at {tiny_kitti} (from $INPAINTENV_KITTI_ROOT" in err
    rows = json.loads((tmp_path / "b" / "results.json").read_text())["rows"]
    assert [r["frame_id"] for r in rows] == ["2011_10_03_drive_0047_sync/image_02/0000000000"]
    assert main(["evaluate", "-m", "scanline", "--split", "val", "-q", "--out", str(tmp_path / "e")]) == 0
    rows = json.loads((tmp_path / "e" / "results.json").read_text())["rows"]
    assert rows[0]["drive"] == "2011_10_03_drive_0047_sync"


def test_kitti_root_option_wins_over_the_variable(tiny_kitti, monkeypatch, capsys, tmp_path):
    monkeypatch.setenv("INPAINTENV_KITTI_ROOT", str(tmp_path / "nowhere"))
    assert info_json(["--kitti-root", str(tiny_kitti)], capsys)["frames"] == 2
    monkeypatch.setenv("INPAINTENV_KITTI_ROOT", "")  # set but empty: as if unset
    assert info_json(TINY, capsys)["source"] == "SyntheticStreets"


@pytest.mark.parametrize("command", ["info", "evaluate", "show", "benchmark", "train"])
@pytest.mark.parametrize("option", [["--split", "val"], ["--camera", "image_03"]])
def test_kitti_only_options_are_refused_without_a_kitti_root(command, option, capsys, tmp_path):
    # --split val was dropped without a word and the synthetic data scored.
    out = tmp_path / ("out.png" if command == "show" else "out")
    argv = [command, *option, "--out", str(out)] if command != "info" else [command, *option]
    if command in ("evaluate", "benchmark"):
        argv += ["-m", "scanline"]
    assert main(argv) == 1
    err = capsys.readouterr().err.strip()
    assert err == (f"inpaintenv {command}: error: {option[0]} applies to KITTI data only, but no KITTI root is in "
                   "effect (give --kitti-root PATH or set INPAINTENV_KITTI_ROOT)")
    assert not out.exists()  # refused before anything was written


def test_synthetic_switch_refuses_kitti_options_and_excludes_kitti_root(tiny_kitti, monkeypatch, capsys):
    monkeypatch.setenv("INPAINTENV_KITTI_ROOT", str(tiny_kitti))
    assert main(["info", "--synthetic", "--split", "val"]) == 1
    assert "--split applies to KITTI data only, but --synthetic is given" in capsys.readouterr().err
    with pytest.raises(SystemExit):  # argparse: not allowed with
        main(["info", "--synthetic", "--kitti-root", str(tiny_kitti)])
    assert "not allowed with argument" in capsys.readouterr().err


@pytest.mark.parametrize("option", [["--frame-shape", "32", "96"], ["--data-seed", "3"]])
def test_synthetic_only_options_are_refused_with_kitti(tiny_kitti, monkeypatch, capsys, option):
    monkeypatch.setenv("INPAINTENV_KITTI_ROOT", str(tiny_kitti))
    assert main(["info", *option]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert f"{option[0]} applies to the synthetic source only, but KITTI is in effect from " in err
    assert "add --synthetic for the built-in data" in err
    assert main(["info", "--kitti-root", str(tiny_kitti), *option]) == 1
    assert "--synthetic" not in capsys.readouterr().err  # the option, not the variable, chose KITTI


def test_empty_kitti_root_is_not_the_current_folder(tiny_kitti, monkeypatch, capsys):
    monkeypatch.chdir(tiny_kitti)  # a KITTI tree here would otherwise be read
    assert main(["info", "--kitti-root", ""]) == 1
    assert "--kitti-root is empty" in capsys.readouterr().err
    from inpaintenv.data import KittiDepth

    with pytest.raises(ValueError, match="KITTI root is an empty string"):
        KittiDepth("")


def test_kind_help_fits_train_too():
    # `train --kind` said "ground truth to score against".
    from inpaintenv.cli import build_parser

    sub = build_parser()._subparsers._group_actions[0].choices["train"]
    kind = next(a for a in sub._actions if a.dest == "kind")
    assert "trained on" in kind.help and "velodyne_raw" in kind.help
