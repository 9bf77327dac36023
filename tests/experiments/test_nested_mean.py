"""experiments/nested_mean.py: each reported fold chooses between two recipes and their mean on its own training days."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

DRIVES = ["2011_09_26_drive_0001_sync", "2011_09_26_drive_9001_sync", "2011_09_30_drive_9018_sync",
          "2011_10_03_drive_9027_sync", "2011_10_03_drive_9034_sync"]


def test_outer_folds_never_train_or_choose_on_what_they_report(load_experiment):
    script = load_experiment("nested_mean")
    folds = {f["name"]: f for f in script.outer_folds(DRIVES)}
    assert list(folds) == ["day-2011_09_26", "day-2011_09_30", "day-2011_10_03", "drive-0001"]
    for fold in folds.values():
        for split in fold["inner"]:
            assert set(fold["held"]) <= set(split["exclude"])  # the reported drives are in no inner training set
            assert not set(fold["held"]) & set(split["score"])  # nor scored to choose
            assert set(split["score"]) <= set(split["exclude"])
            assert set(DRIVES) - set(split["exclude"])  # something is left to train on
    assert [s["day"] for s in folds["day-2011_09_30"]["inner"]] == ["2011_09_26", "2011_10_03"]
    official = folds["drive-0001"]["inner"]
    assert [s["score"] for s in official] == [["2011_09_26_drive_9001_sync"], ["2011_09_30_drive_9018_sync"],
                                              ["2011_10_03_drive_9027_sync", "2011_10_03_drive_9034_sync"]]
    assert "drive-0001" not in {f["name"] for f in script.outer_folds(DRIVES[1:])}


def test_training_sets_are_named_by_what_they_leave_out(load_experiment):
    script = load_experiment("nested_mean")
    days = {f["name"]: f for f in script.outer_folds(DRIVES)}
    tags = {script.training_tag(s["exclude"], DRIVES) for f in days.values() for s in f["inner"]}
    # the day folds' inner splits share three single-day training sets; drive 0001's adds its own
    assert tags == {"2011_09_26+2011_09_30", "2011_09_26+2011_10_03", "2011_09_30+2011_10_03", "2011_09_26",
                    "0001+2011_09_30", "0001+2011_10_03"}
    assert script.lodo_folder("2011_09_26") == "day-2011_09_26" and script.lodo_folder("0001") == "drive-0001"
    assert script.lodo_folder("0001+2011_09_30") is None


@pytest.fixture(scope="module")
def three_days(tmp_path_factory):
    """A drive of one frame on each of three days, in the KITTI layout."""
    from inpaintenv.data.io import write_depth_png

    root = tmp_path_factory.mktemp("kitti3")
    rng = np.random.default_rng(0)
    rows = np.arange(375, dtype=np.float32)[:, None]
    for drive in ("2011_09_26_drive_9001_sync", "2011_09_30_drive_9018_sync", "2011_10_03_drive_9027_sync"):
        folder = root / "train" / drive / "proj_depth" / "groundtruth" / "image_02"
        folder.mkdir(parents=True)
        for k in range(1):
            depth = np.broadcast_to(1500.0 / (rows + 30.0 + k), (375, 1242)).copy()
            depth[rng.random(depth.shape) < 0.4] = 0.0
            write_depth_png(folder / f"000000000{k}.png", depth.astype(np.float32))
    return root


def _place(model: Path, folder: Path) -> None:
    """A saved model at ``folder/model``, as a training run leaves it."""
    shutil.copytree(model, folder / "model")


def test_scores_three_candidates_per_fold_and_records_the_choice(three_days, tmp_path, capsys, load_experiment,
                                                                 tiny_models):
    script = load_experiment("nested_mean")
    out = tmp_path / "nested"
    args = ["--kitti-root", str(three_days), "--out", str(out), "-m", "harmonic", "--seed", "0",
            "--fold", "day-2011_09_30"]
    assert script.main(args) == 1  # models missing, no --train: says which
    assert "missing inner models" in capsys.readouterr().err
    for tag in ("2011_09_26+2011_09_30", "2011_09_30+2011_10_03"):
        _place(tiny_models["context"], out / f"train-without-{tag}-context-kitti-draws")
        _place(tiny_models["blend"], out / f"train-without-{tag}-blend-kitti")
    assert script.main(args) == 0
    printed = capsys.readouterr().out
    assert "## fold day-2011_09_30: inner splits leave out 2011_09_26, 2011_10_03" in printed
    assert printed.count("(chosen)") == 1
    choices = json.loads((out / "choices.json").read_text())
    assert choices[0]["fold"] == "day-2011_09_30" and choices[0]["choice"] in ("first", "second", "mean")
    assert choices[0]["choice"] == min(choices[0]["ratios"], key=choices[0]["ratios"].get)
    assert (out / "inner-day-2011_09_30.json").is_file()
    # a rerun adds a weighted mean, scoring only it (the saved rows are reused), and scores
    # the mean candidates on the fold's reported frames with its linked fold models
    before = json.loads((out / "inner-day-2011_09_30.json").read_text())["rows"]
    lodo = tmp_path / "lodo"
    _place(tiny_models["context"], lodo / "train-day-2011_09_30-context-kitti-draws")
    _place(tiny_models["blend"], lodo / "train-day-2011_09_30-blend-kitti")
    assert script.main([*args, "--weight", "0.7", "--outer", "--link", str(lodo)]) == 0
    printed = capsys.readouterr().out
    assert "| mean-w0.7" in printed and "reported frames of fold day-2011_09_30" in printed
    after = json.loads((out / "inner-day-2011_09_30.json").read_text())["rows"]
    assert len(after) == len(before) + len([r for r in before if r["method"] == "mean"])
    assert [r for r in after if r["method"] != "mean-w0.7"] == before
    choices = json.loads((out / "choices.json").read_text())
    assert set(choices[0]["ratios"]) == {"first", "second", "mean", "mean-w0.7"}
    assert set(choices[0]["outer"]) == {"mean", "mean-w0.7"}
    chosen = choices[0]["choice"]  # marked in the inner table, and in the reported one if a mean
    if chosen.startswith("mean"):
        assert printed.count("(chosen)") == 2
    else:
        assert printed.count("(chosen)") == 1 and f"(chosen: {chosen}, a single model" in printed
    with pytest.raises(SystemExit):
        script.main([*args, "--weight", "1.5"])
    # a classical share: one more candidate, scored from the same predictions
    assert script.main([*args, "--share", "harmonic:0.25", "--outer", "--by-drive", "--link", str(lodo)]) == 0
    assert "| 2011_09_30_drive_9018_sync | " in capsys.readouterr().out
    outer = json.loads((out / "outer-day-2011_09_30.json").read_text())["rows"]
    assert {r["method"] for r in outer} == {"mean", "mean+harmonic-s0.25", "harmonic"}
    shared = json.loads((out / "inner-day-2011_09_30.json").read_text())["rows"]
    assert [r for r in shared if r["method"] != "mean+harmonic-s0.25"] == after
    assert "mean+harmonic-s0.25" in json.loads((out / "choices.json").read_text())[0]["ratios"]
    assert script.main([*args, "--gate", "harmonic:1:0"]) == 0
    assert "mean+harmonic-s1-if-farther-0" in json.loads((out / "choices.json").read_text())[0]["ratios"]
    with pytest.raises(SystemExit):  # per-drive ratios come from the reported rows only
        script.main([*args, "--by-drive"])
    assert "--by-drive reads the reported rows" in capsys.readouterr().err
    for bad in ("scanline:0.2", "harmonic:1", "harmonic"):  # not among -m; share out of (0, 1); no share
        with pytest.raises(SystemExit):
            script.main([*args, "--share", bad])


def test_mix_is_the_shared_weighted_sum_of_memoised_predictions(load_experiment):
    script = load_experiment("nested_mean")
    calls = []

    class Constant:
        def __init__(self, value):
            self.value = value

        def predict(self, depth):
            calls.append(self.value)
            return np.full(depth.shape, self.value)

    first, second = script.Memo(Constant(10.0)), script.Memo(Constant(20.0))
    depth = np.ones((2, 3, 4), dtype=np.float32)
    mix = script.Mix(first, second, 0.25)
    np.testing.assert_allclose(mix.predict(depth), 12.5)
    np.testing.assert_allclose(script.Mix(first, second, 0.5).predict(depth), 15.0)
    assert calls == [10.0, 20.0]  # each member predicted once for the same batch
    first.predict(depth + 1)
    assert calls == [10.0, 20.0, 10.0]  # a new batch is predicted again
    assert script.parse_mix("harmonic:0.2", ["harmonic"]) == ("harmonic", 0.2)


def test_gate_mixes_only_the_frames_where_the_classical_fill_is_farther(load_experiment):
    script = load_experiment("nested_mean")

    class Fixed:
        def __init__(self, frames):
            self.frames = frames

        def predict(self, depth):
            return self.frames

    depth = np.full((2, 2, 3), np.nan, dtype=np.float32)
    depth[:, 0, 0] = 5.0  # one measured pixel per frame, the rest is the hole
    mean = np.full((2, 2, 3), 10.0, dtype=np.float32)
    far = np.stack([np.full((2, 3), 20.0), np.full((2, 3), 10.5)]).astype(np.float32)  # log 2 and log 1.05
    gate = script.Mix(script.Memo(Fixed(mean)), script.Memo(Fixed(far)), 0.5, farther_than=0.2)
    out = gate.predict(depth)
    np.testing.assert_allclose(out[0], 15.0)  # farther by log 2 > 0.2: mixed
    np.testing.assert_allclose(out[1], 10.0)  # farther by log 1.05 < 0.2: the mean
    assert script.parse_mix("scanline:1:0.15", ["scanline"], gated=True) == ("scanline", 1.0, 0.15)
    for bad in ("scanline:0.5", "scanline:0:0.1", "scanline:0.5:-1", "harmonic:0.5:0.1"):
        with pytest.raises(ValueError, match="--gate takes METHOD:S:T"):
            script.parse_mix(bad, ["scanline"], gated=True)
