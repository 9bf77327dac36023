"""experiments/probe_gate.py: probes beside the hole, exact scores of any linear mix from their statistics."""

from __future__ import annotations

import numpy as np
import pytest

from estimators.classical import HarmonicInpainter, ScanlineInpainter
from inpaintenv.conventions import corrupt
from inpaintenv.data import SyntheticStreets
from inpaintenv.masks import get_protocol


def test_probes_are_shifted_copies_outside_the_hole_with_a_margin(load_experiment):
    probe_regions = load_experiment("blend_probes").probe_regions
    hole = np.zeros((40, 200), bool)
    hole[10:20, 80:100] = True  # width 20 -> margin 8 (min), shift 28
    hole[30:35, 0:10] = True  # at the left edge: only the right-hand probe fits
    probes, labels, n = probe_regions(hole, "h", margin=0.25, min_margin=8)
    assert n == 3 and not (probes[hole] > 0).any()
    first = labels[15, 85]
    rows, cols = np.nonzero(probes == first)
    assert set(rows) == set(range(10, 20))
    assert set(cols) == set(range(52, 72)) | set(range(108, 128))
    cols = np.nonzero(probes == labels[32, 5])[1]
    assert cols.min() == 18 and cols.max() == 27  # 10 wide, shifted by 10 + 8 to the right only
    # without a margin the copies touch the hole, as blend_probes' self-validation features had them
    probes, labels, _ = probe_regions(hole, "h")
    assert set(np.nonzero(probes == labels[15, 85])[1]) == set(range(60, 80)) | set(range(100, 120))


def test_simplex_lsq_matches_a_grid_search(load_experiment):
    script = load_experiment("probe_gate")
    rng = np.random.default_rng(0)
    preds = rng.normal(10, 3, (3, 500))
    truth = 0.3 * preds[0] + 0.7 * preds[2] + rng.normal(0, 0.5, 500)
    g, c = preds @ preds.T, preds @ truth
    w = script.simplex_lsq(g, c)
    assert w.min() >= 0 and np.isclose(w.sum(), 1)
    grid = [np.array([a, b, 1 - a - b]) for a in np.linspace(0, 1, 101) for b in np.linspace(0, 1, 101) if a + b <= 1]
    best = min(grid, key=lambda v: np.sum((v @ preds - truth) ** 2))
    assert np.sum((w @ preds - truth) ** 2) <= np.sum((best @ preds - truth) ** 2) + 1e-6
    # strong shrinkage returns the prior
    prior = np.array([1.0, 0.0, 0.0])
    assert np.allclose(script.simplex_lsq(g, c, prior, 1e12), prior, atol=1e-4)


@pytest.fixture(scope="module")
def collected(load_experiment):
    script = load_experiment("probe_gate")
    frames = SyntheticStreets(n=4, frame_shape=(96, 320), seed=1)
    methods = [("scanline", ScanlineInpainter()), ("harmonic", HarmonicInpainter())]
    data = script.collect(methods, frames, [0, 1], progress=False)
    return script, frames, data


def test_statistics_give_each_method_its_own_hole_rmse(collected):
    script, frames, data = collected
    assert data["methods"] == ["scanline", "harmonic"] and len(data["index"]) == 8
    assert data["hole"].shape == data["probe"].shape == data["hole_single"].shape
    proto = get_protocol("rect-v1")
    direct = []
    for seed in (0, 1):
        for i in range(len(frames)):
            gt = frames[i]
            hole = proto.mask(gt.shape, seed, i)
            pred = HarmonicInpainter().predict(corrupt(gt, hole))
            sel = hole & (gt > 0)
            direct.append(np.sqrt(np.mean((pred[sel] - gt[sel]) ** 2)) if sel.any() else np.nan)
    from_stats = script.frame_rmse(data, np.tile([0.0, 1.0], (len(data["hole"]), 1)))
    np.testing.assert_allclose(from_stats, direct, rtol=1e-5)


def test_score_reports_every_rule_against_the_strongest_classical(collected):
    script, _, data = collected
    res = script.score(data, shrinks=(100.0,), single_pass=True)
    assert res["learned"] == "scanline" and res["strongest"] == "harmonic"
    assert {"oracle", "gate", "gate-comp", "inverse-mse", "lsq", "shrink-100", "scanline (single pass)"} <= set(res["ratios"])
    assert res["ratios"]["harmonic"][0] == pytest.approx(1.0)
    # the hindsight choice is never worse than either method
    assert res["rmse"]["oracle"] <= min(res["rmse"]["scanline"], res["rmse"]["harmonic"]) + 1e-9
    restricted = script.score(data, use=["scanline"])
    assert restricted["mixed"] == ["scanline"]
    assert restricted["rmse"]["lsq"] == pytest.approx(restricted["rmse"]["scanline"])
    agreement = res["agreement"]
    assert 0 < agreement["n"] <= res["n"] and -1 <= agreement["correlation"] <= 1
    assert 0 <= agreement["learned_wins_hole"] <= 1 and 0 <= agreement["learned_wins_probes"] <= 1


def test_agreement_is_perfect_when_probes_and_hole_rank_alike(collected):
    script, _, data = collected
    same = {**data, "probe": data["hole"]}
    a = script.probe_agreement(same)
    assert a["correlation"] == pytest.approx(1.0) and a["learned_wins_hole"] == a["learned_wins_probes"]


def test_score_names_a_missing_file(load_experiment, tmp_path):
    with pytest.raises(SystemExit, match="no such file"):
        load_experiment("probe_gate").load(tmp_path / "absent.npz")

