"""export -> a separate process writing PNGs -> score gives evaluate()'s rows, bit for bit.

The method is docs/examples/fill_holes.py, run as its own process with only OpenCV. Its
scores through files must be exactly those of evaluate() on the same method with its
input and output rounded to 1/256 m as the PNGs store them; on KITTI the exported inputs
are the ground truth itself (already on the 1/256 m grid), so only the output is rounded.
"""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from inpaintenv.data import open_source
from inpaintenv.envs import DepthInpaintEnv
from inpaintenv.evaluate import evaluate
from inpaintenv.report.results import ID_COLUMNS, METRIC_COLUMNS
from inpaintenv.submission import export, score

COMPARED = tuple(c for c in ID_COLUMNS if c != "method") + ("hole_fraction",) + METRIC_COLUMNS


def assert_same_rows(scored, reference) -> None:
    """Every identifying and metric column equal, bit for bit (NaN equal to NaN)."""
    key = lambda r: (r["seed"], r["index"])
    a, b = sorted(scored.rows, key=key), sorted(reference.rows, key=key)
    assert [key(r) for r in a] == [key(r) for r in b] and a
    for ra, rb in zip(a, b):
        for c in COMPARED:
            same = ra[c] == rb[c] or (isinstance(ra[c], float) and math.isnan(ra[c]) and math.isnan(rb[c]))
            assert same, f"{c} of seed {ra['seed']} frame {ra['index']}: {ra[c]!r} through files, {rb[c]!r} in-process"


def round_trip(tmp_path, source, run_fill, fill_method, seeds, kitti_root=None):
    manifest = export(tmp_path / "inputs", source, "rect-v1", seeds, progress=False, trusted=len(seeds) > 1)
    run_fill(tmp_path / "inputs", tmp_path / "predictions")
    # The root explicitly: tests run without $INPAINTENV_KITTI_ROOT (tests/conftest.py).
    scored = score(manifest.path, tmp_path / "predictions", name="telea-script", kitti_root=kitti_root)
    reference = evaluate(fill_method, source, "rect-v1", seeds, progress=False, name="telea-script")
    return manifest, scored, reference


def test_synthetic_round_trip_equals_evaluate(tmp_path, streets, run_fill, fill_method):
    manifest, scored, reference = round_trip(tmp_path, streets, run_fill, fill_method, [0, 3])
    assert_same_rows(scored, reference)
    assert len(scored.rows) == len(manifest.items) == 2 * len(streets)
    assert all(math.isnan(r["ms"]) for r in scored.rows)  # the method ran elsewhere


def check_inputs_are_env_observations(manifest, source, exact: bool) -> int:
    """Compare every exported (input, hole) with the env's observation of (frame, seed); returns pairs compared."""
    env = DepthInpaintEnv(source, "rect-v1")
    compared = 0
    for item in manifest.items:
        obs, info = env.reset(options={"index": item.index, "mask_seed": item.seed})
        if info["mask_redraws"]:
            continue  # the env redraws a hole without ground truth; evaluate() and export do not
        raw = cv2.imread(str(manifest.root / item.input), cv2.IMREAD_UNCHANGED)
        hole = cv2.imread(str(manifest.root / item.hole), cv2.IMREAD_UNCHANGED)
        assert raw.dtype == np.uint16 and hole.dtype == np.uint8
        np.testing.assert_array_equal(hole, obs["hole"] * 255)
        if exact:  # KITTI ground truth is on the 1/256 m grid already
            np.testing.assert_array_equal(raw.astype(np.float32) / 256, obs["depth"])
        else:
            np.testing.assert_array_equal(raw, np.rint(obs["depth"].astype(np.float64) * 256))
        compared += 1
    return compared


def test_synthetic_inputs_are_the_env_observations(tmp_path, streets):
    manifest = export(tmp_path / "inputs", streets, "rect-v1", [0, 1], progress=False, trusted=True)
    assert check_inputs_are_env_observations(manifest, streets, exact=False) >= len(manifest.items) - 2


@pytest.fixture(scope="module")
def kitti_run(kitti_root, tmp_path_factory, run_fill, fill_method):
    """A round trip on the real slice: the official val frame and the first train frames."""
    tmp = tmp_path_factory.mktemp("kitti-round-trip")
    source = open_source(kitti_root, split="val,train", n_frames=3)
    manifest, scored, reference = round_trip(tmp, source, run_fill, fill_method, [0, 1], kitti_root=kitti_root)
    return source, manifest, scored, reference, tmp / "predictions"


def test_kitti_round_trip_equals_evaluate(kitti_run):
    _, _, scored, reference, _ = kitti_run
    assert_same_rows(scored, reference)


def test_kitti_inputs_are_the_env_observations(kitti_run):
    source, manifest, *_ = kitti_run
    assert check_inputs_are_env_observations(manifest, source, exact=True) >= len(manifest.items) - 1


def test_all_pixel_metrics_are_the_kitti_devkit_formulas(kitti_run, kitti_root):
    """Per frame, over every pixel with ground truth, from the PNG files alone: RMSE and MAE in
    metres, iRMSE and iMAE in 1/km (evaluate_depth.cpp's sums; it prints 1/m, the leaderboard 1/km)."""
    _, manifest, scored, _, predictions = kitti_run
    rows = {(r["seed"], r["index"]): r for r in scored.rows}
    h, w = manifest.frame_shape
    for item in manifest.items:
        full = cv2.imread(str(kitti_root / manifest.frames[item.index].ground_truth), cv2.IMREAD_UNCHANGED)
        top, left = full.shape[0] - h, (full.shape[1] - w) // 2  # the bottom-centre crop of the manifest
        gt = full[top:, left : left + w].astype(np.float64) / 256
        pred = cv2.imread(str(predictions / item.input), cv2.IMREAD_UNCHANGED).astype(np.float64) / 256
        valid = gt > 0
        err = gt[valid] - pred[valid]
        inv_err = 1000.0 / gt[valid] - 1000.0 / pred[valid]  # 1/km
        row = rows[(item.seed, item.index)]
        assert row["all_count"] == valid.sum()
        assert row["all_rmse"] == pytest.approx(np.sqrt(np.mean(err**2)), rel=1e-12)
        assert row["all_mae"] == pytest.approx(np.mean(np.abs(err)), rel=1e-12)
        assert row["all_irmse"] == pytest.approx(np.sqrt(np.mean(inv_err**2)), rel=1e-12)
        assert row["all_imae"] == pytest.approx(np.mean(np.abs(inv_err)), rel=1e-12)
