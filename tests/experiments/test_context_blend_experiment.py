"""experiments/context_blend.py: cache a tiny KITTI tree, fit variants per fold, score their ensemble."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

pytest.importorskip("torch")

DRIVES = [("train", "2011_09_26_drive_0001_sync"), ("train", "2011_09_26_drive_9001_sync"),
          ("train", "2011_09_30_drive_9018_sync"), ("val", "2011_10_03_drive_9101_sync")]


@pytest.fixture(scope="module")
def two_day_kitti(tmp_path_factory):
    """Two recording days, drive 0001 and a val drive; one frame each (KittiDepth crops 352x1216)."""
    from inpaintenv.data.io import write_depth_png

    root = tmp_path_factory.mktemp("kitti2")
    rng = np.random.default_rng(0)
    for split, drive in DRIVES:
        folder = root / split / drive / "proj_depth" / "groundtruth" / "image_02"
        folder.mkdir(parents=True)
        for frame in (5,):
            depth = np.where(rng.random((375, 1242)) < 0.3, 5.0 + 20 * rng.random((375, 1242)), 0.0)
            write_depth_png(folder / f"{frame:010d}.png", depth.astype(np.float32))
    return root


def test_fit_prints_each_variant_and_their_ensemble_per_fold(load_experiment, two_day_kitti, tmp_path, capsys):
    ctx = load_experiment("context_blend")
    cache = tmp_path / "cache"
    ctx.main(["cache", "--kitti-root", str(two_day_kitti), "--out", str(cache), "--train-masks", "1",
              "--pixels", "64", "--jobs", "1"])
    tiny = {"context": 2, "balance": 1.0, "widths": (4, 8), "width": 8, "layers": 1, "epochs": 30}
    ctx.VARIANTS["tiny-a"] = tiny
    ctx.VARIANTS["tiny-b"] = {**tiny, "seed": 1}
    capsys.readouterr()
    ctx.main(["fit", "--cache", str(cache), "--variant", "tiny-a", "--variant", "tiny-b", "--ensemble",
              "--epochs", "1", "--threads", "1"])
    lines = capsys.readouterr().out.strip().splitlines()
    ratios = json.loads(lines[-1])
    folds = {"day 2011_09_26", "day 2011_09_30", "drive 0001 (official)", "val 9101 (check)"}
    for name in ("tiny-a", "tiny-b", "tiny-a+tiny-b"):
        assert {key.split("|")[1] for key in ratios if key.split("|")[0] == name} == folds
    assert all(r > 0 for r in ratios.values())
    # the members differ (another seed), and the ensemble's error is at most the worse member's
    # on every frame-mask set: RMSE is convex in the prediction
    rows = [line for line in lines if "|" in line and "ratio" in line]
    by = {(r.split("|")[0].strip(), r.split("|")[1].strip()): float(re.search(r"\| +([\d.]+) m vs", r).group(1))
          for r in rows}
    assert any(by[("tiny-a", f)] != by[("tiny-b", f)] for f in folds)
    for f in folds:
        assert by[("ensemble", f)] <= max(by[("tiny-a", f)], by[("tiny-b", f)]) + 1e-6

    # --preds: members trained in separate runs, then read back (not trained) for the ensemble
    preds = tmp_path / "preds"
    for member in ("tiny-a", "tiny-b"):
        ctx.main(["fit", "--cache", str(cache), "--variant", member, "--preds", str(preds), "--epochs", "1",
                  "--threads", "1"])
    capsys.readouterr()
    ctx.main(["fit", "--cache", str(cache), "--variant", "tiny-a", "--variant", "tiny-b", "--ensemble",
              "--preds", str(preds)])
    out = capsys.readouterr().out
    assert "fit " not in out and out.count("predictions from") == 2 * len(folds)
    assert json.loads(out.strip().splitlines()[-1]) == pytest.approx(ratios)
    # the same members without the mirrored-frame average: other numbers, still read back
    ctx.main(["fit", "--cache", str(cache), "--variant", "tiny-a", "--variant", "tiny-b", "--ensemble",
              "--preds", str(preds), "--no-tta"])
    out = capsys.readouterr().out
    assert out.count("predictions from") == 2 * len(folds)
    assert json.loads(out.strip().splitlines()[-1]) != pytest.approx(ratios)
    # another --seed trains another model: the kept predictions are not read back for it
    ctx.main(["fit", "--cache", str(cache), "--variant", "tiny-a", "--preds", str(preds), "--seed", "5",
              "--threads", "1", "--folds", "day 2011_09_30"])
    out = capsys.readouterr().out
    assert "predictions from" not in out and "fit " in out


def test_select_chooses_on_held_out_training_drives_only(load_experiment, two_day_kitti, tmp_path, capsys,
                                                         monkeypatch):
    ctx = load_experiment("context_blend")
    cache = tmp_path / "cache"
    ctx.main(["cache", "--kitti-root", str(two_day_kitti), "--out", str(cache), "--train-masks", "1",
              "--pixels", "64", "--jobs", "1"])
    tiny = {"context": 2, "balance": 1.0, "widths": (4, 8), "width": 8, "layers": 1, "epochs": 2}
    # the variants measured for issue 23, at toy size: row coordinates, a context candidate
    ctx.VARIANTS["tiny-coord"] = {**tiny, "coords": True}
    ctx.VARIANTS["tiny-cand"] = {**tiny, "context_candidate": True}
    calls = []  # (drives trained on, drives scored) of every inner split
    train_fold, predict = ctx.train_fold, ctx.predict_samples

    def recording_train(cache_, idx, *a, **kw):
        calls.append(({cache_.meta[k]["drive"] for k in idx}, set()))
        return train_fold(cache_, idx, *a, **kw)

    def recording(net, cache_, idx, variant):
        calls[-1][1].update(cache_.meta[k]["drive"] for k in idx)
        return predict(net, cache_, idx, variant)

    monkeypatch.setattr(ctx, "train_fold", recording_train)
    monkeypatch.setattr(ctx, "predict_samples", recording)
    with pytest.raises(SystemExit, match="--inner must be at least 2"):
        ctx.main(["select", "--cache", str(cache), "--variant", "tiny-coord", "--inner", "1"])
    assert not calls
    capsys.readouterr()
    ctx.main(["select", "--cache", str(cache), "--variant", "tiny-coord", "--variant", "tiny-cand", "--inner", "2",
              "--threads", "1"])
    out = capsys.readouterr().out
    summary = json.loads(out.strip().splitlines()[-1])
    # day 2011_09_26 leaves one training drive (9018): nothing to choose on
    assert "day 2011_09_26: fewer than 2 training drives" in out
    assert set(summary) == {"day 2011_09_30", "drive 0001 (official)"}
    for fold, result in summary.items():
        assert result["choice"] in ("tiny-coord", "tiny-cand")
        assert set(result["inner_ratio"]) == {"tiny-coord", "tiny-cand"}
        assert all(r > 0 for r in result["inner_ratio"].values())
    # every split scores drives it did not train on, all among the fold's own training drives:
    # never the left-out day (2011_09_30) or drive 0001's official maps that `fit` reports
    d0001, d9001, d9018 = (d for _, d in DRIVES[:3])
    assert len(calls) == 2 * 2 * 2  # folds x variants x inner splits
    for trained, held in calls:
        assert held and not trained & held
        assert trained | held in ({d0001, d9001}, {d9001, d9018})
