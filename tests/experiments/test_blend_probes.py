"""experiments/blend_probes.py and blend_context.py: the probes of what limits the learned blend."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("torch")


@pytest.fixture(scope="module")
def probes(load_experiment):
    return load_experiment("blend_probes")


def test_probe_regions_are_the_holes_shifted_copies_outside_it(probes):
    hole = np.zeros((40, 60), bool)
    hole[10:20, 20:30] = True
    probe, _, n = probes.probe_regions(hole, "h")
    assert n == 2 and not (probe[hole]).any()
    assert np.array_equal(np.argwhere(probe == 1), np.argwhere(np.roll(hole, 10, 1) | np.roll(hole, -10, 1)))
    vertical, _, _ = probes.probe_regions(hole, "v")
    assert np.array_equal(vertical > 0, np.roll(hole, 10, 0) | np.roll(hole, -10, 0))
    edge = np.zeros((40, 60), bool)
    edge[0:10, 0:8] = True  # the left copy falls outside the image: only the right one remains
    probe, _, _ = probes.probe_regions(edge, "h")
    assert np.array_equal(probe > 0, np.roll(edge, 8, 1))
    with pytest.raises(ValueError, match="direction"):
        probes.probe_regions(hole, "x")


def test_self_validation_ranks_the_exact_candidate_first(probes):
    # Depth linear along rows and constant along columns: row-wise linear interpolation
    # of depth (scanline) is exact on the probes, the inverse-depth fills are not.
    depth = np.tile(np.linspace(5, 50, 120, dtype=np.float32), (40, 1))
    x = depth.copy()
    x[10:20, 40:60] = np.nan
    feats = probes.self_validation(x, ("scanline", "scanline-inverse"), "h")
    inside, outside = feats[:, 15, 50], feats[:, 0, 0]
    assert inside[0] == 0 and inside[1] > 0 and inside[3] == 1  # scanline best, probe counted
    assert not outside.any()


def _tiny_cache(probes, path):
    rng = np.random.default_rng(0)
    n_cols = probes.HARMONIC + 1
    drives = ["a_sync", "b_sync", "c_sync"]

    def block(n_samples, px, kind):
        x = rng.uniform(5, 30, (n_samples * px, n_cols)).astype(np.float32)
        x[:, probes.K:probes.K + 4] = rng.integers(1, 40, (len(x), 4))
        return {"x": x, "y": x[:, 0] * 0.9 + 1, "sample": np.repeat(np.arange(n_samples), px).astype(np.int32)}

    meta = {"eval": [{"split": "train", "drive": d, "kind": "eval"} for d in drives for _ in range(2)]
            + [{"split": "val", "drive": "v_sync", "kind": "eval"}],
            "train": [{"split": "train", "drive": d, "kind": "train"} for d in drives for _ in range(2)]}
    for kind, m in meta.items():
        np.savez(path / f"{kind}.npz", **block(len(m), 64, kind))
        (path / f"{kind}.json").write_text(json.dumps(m))
    return drives


def test_oracle_is_never_worse_than_the_best_single_candidate(probes, tmp_path):
    drives = _tiny_cache(probes, tmp_path)
    out = probes.main(["oracle", "--cache", str(tmp_path)])
    assert set(out) == set(drives) | {"v_sync"}
    for row in out.values():
        assert 0 < row["pixel_oracle"] <= row["frame_oracle"] <= 1.0 + 1e-9


def test_fit_scores_each_held_out_drive_and_val(probes, tmp_path):
    drives = _tiny_cache(probes, tmp_path)
    out = probes.main(["fit", "--cache", str(tmp_path), "--variant", "svh", "--epochs", "1",
                       "--far-weight", "1", "--json", str(tmp_path / "fit.json")])
    rows = out["svh far-weight 1"]
    assert set(rows) == set(drives) | {f"val (model without {d})" for d in drives}
    assert all(r["ratio"] > 0 and r["ci"][0] <= r["ratio"] <= r["ci"][1] for r in rows.values())
    # Falling back per frame to the classical fill is never worse than either alone.
    assert all(r["gate_oracle"] <= min(r["ratio"], 1.0) + 1e-9 for r in rows.values())
    assert json.loads((tmp_path / "fit.json").read_text()) == json.loads(json.dumps(out))


def test_context_net_starts_as_the_blend_and_inputs_are_scale_free(load_experiment):
    import torch

    ctx = load_experiment("blend_context")
    rng = np.random.default_rng(1)
    gt = rng.uniform(5, 40, (32, 48)).astype(np.float32)
    gt[rng.random(gt.shape) < 0.5] = 0
    x = np.where(gt > 0, gt, 0).astype(np.float32)
    x[8:16, 8:24] = np.nan
    # the blend fills every unmeasured pixel (LiDAR gaps too), so it is positive everywhere
    blend = np.where(np.isnan(x) | (x == 0), 20.0, x).astype(np.float32)
    inputs, targets = ctx.lowres_inputs(x, blend, gt)
    scaled, _ = ctx.lowres_inputs(3 * x, 3 * blend, 3 * gt)
    assert inputs.shape == (4, 8, 12) and targets.shape == (3, 8, 12)
    np.testing.assert_allclose(inputs, scaled, atol=1e-5)  # log-depths relative to the frame's median
    assert targets[0].sum() == ((gt > 0) & np.isnan(x)).sum()
    net = ctx.ContextNet()
    assert not net(torch.from_numpy(inputs[None])).abs().sum()  # zero-initialised head: blend unchanged
    trained = ctx.train_context(torch.from_numpy(np.stack([inputs] * 8)), torch.from_numpy(np.stack([targets] * 8)),
                                epochs=1, seed=0)
    assert torch.isfinite(trained(torch.from_numpy(inputs[None]))).all()


@pytest.mark.slow
def test_cache_then_oracle_on_a_kitti_tree(probes, load_experiment, tiny_kitti, tmp_path):
    cache = tmp_path / "cache"
    probes.main(["cache", "--kitti-root", str(tiny_kitti), "--out", str(cache), "--seeds", "0",
                 "--train-masks", "1", "--pixels", "200", "--jobs", "1"])
    meta = json.loads((cache / "train.json").read_text())
    assert len(meta) == 3 * len(probes.KEEP)  # one occlusion per train frame, one input per keep fraction
    with np.load(cache / "eval.npz") as z:
        assert z["x"].shape[1] == probes.HARMONIC + 1 and len(np.unique(z["sample"])) == 4
    assert set(probes.main(["oracle", "--cache", str(cache)])) == {m["drive"] for m in meta} | {
        "2011_10_03_drive_9101_sync"}
    sparse = tmp_path / "sparse"  # evaluation inputs thinned, no training pixels
    probes.main(["cache", "--kitti-root", str(tiny_kitti), "--out", str(sparse), "--seeds", "0",
                 "--train-masks", "0", "--eval-keep", "0.5", "--jobs", "1"])
    assert sorted(p.name for p in sparse.glob("*.npz")) == ["eval.npz"]
    with np.load(cache / "eval.npz") as full, np.load(sparse / "eval.npz") as thinned:
        assert np.array_equal(full["y"], thinned["y"]) and not np.array_equal(full["x"], thinned["x"])
    # blend_lodo's cache shares the frame loop: per-keep training files and a channel list
    lodo = load_experiment("blend_lodo")
    lodo.main(["cache", "--kitti-root", str(tiny_kitti), "--out", str(tmp_path / "lodo"), "--seeds", "0",
               "--train-masks", "1", "--pixels", "200", "--keep", "1.0", "0.65", "--jobs", "1"])
    assert sorted(p.name for p in (tmp_path / "lodo").glob("*.npz")) == ["eval.npz", "train-0.65.npz", "train-1.npz"]
    with np.load(tmp_path / "lodo" / "train-0.65.npz") as z:
        assert z["x"].shape == (3 * 200, len(lodo.CHANNELS)) and set(z) == {"x", "y", "row", "sample"}


def test_time_reports_both_costs_per_frame(probes, tiny_kitti):
    out = probes.main(["time", "--kitti-root", str(tiny_kitti), "--drive", "2011_09_26_drive_9001_sync"])
    assert len(out["features_ms"]) == len(out["self_validation_h_ms"]) == 1  # the drive has one frame
    assert min(out["features_ms"] + out["self_validation_h_ms"]) > 0
