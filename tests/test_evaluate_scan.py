"""evaluate with a single LiDAR scan as the input: what the method is given, what is scored, what is recorded."""

from __future__ import annotations

import json

import numpy as np
import pytest

from estimators.classical import NearestInpainter
from inpaintenv.benchmark.run_state import differences, fingerprint
from inpaintenv.data import KittiDepth, SyntheticStreets, method_input
from inpaintenv.evaluate import evaluate
from inpaintenv.masks import get_protocol
from inpaintenv.metrics import frame_metrics

SHAPE = (48, 160)


@pytest.fixture(scope="module")
def scans() -> SyntheticStreets:
    return SyntheticStreets(n=4, seed=2, frame_shape=SHAPE, frames_per_drive=2, input="scan")


class Recorder:
    """Nearest fill that keeps every input it was given."""

    batched = True
    name = "recorder"

    def __init__(self):
        self.seen: list[np.ndarray] = []

    def __call__(self, x: np.ndarray) -> np.ndarray:
        self.seen.append(x.copy())
        return NearestInpainter(n_jobs=1).predict(x)


@pytest.mark.parametrize("protocol", ["densify-v1", "rect-v1"])
def test_the_method_gets_the_scan_without_the_hole_and_rows_score_it(scans, protocol):
    method = Recorder()
    res = evaluate(method, scans, protocol=protocol, seeds=[1], batch_size=4, progress=False)
    inputs, gt = scans.load_pairs(range(len(scans)))
    hole = get_protocol(protocol).masks(SHAPE, 1, range(len(scans)))
    (x,) = method.seen
    # NaN wherever the scan has no measurement or the hole was cut; the scan's values elsewhere.
    np.testing.assert_array_equal(np.isnan(x), (inputs == 0) | hole)
    np.testing.assert_array_equal(x[~np.isnan(x)], inputs[~np.isnan(x)])
    np.testing.assert_array_equal(x, method_input(inputs, hole, "scan"))
    want = frame_metrics(NearestInpainter(n_jobs=1).predict(x), gt, hole, inputs=inputs)
    assert res.meta["input_kind"] == "scan"
    for k, row in enumerate(res.rows):
        assert row["input_kind"] == "scan"
        assert row["unmeasured_count"] == ((gt[k] > 0) & ((inputs[k] == 0) | hole[k])).sum()
        for key in ("unmeasured_rmse", "kitti_rmse", "kitti_irmse", "hole_count", "all_mae"):
            np.testing.assert_equal(row[key], want[key][k])
    table = res.table[0]
    assert np.isfinite(table["unmeasured_rmse"]) and np.isfinite(table["kitti_rmse"])
    if protocol == "densify-v1":
        assert all(r["hole_count"] == 0 for r in res.rows) and np.isnan(table["hole_rmse"])
        assert table["n_skipped_hole"] == 0 and np.isfinite(table["all_rmse"])
    else:
        assert table["unmeasured_rmse"] != table["hole_rmse"]


def test_a_map_source_scores_as_before_and_says_so():
    ds = SyntheticStreets(n=2, seed=2, frame_shape=SHAPE)
    res = evaluate(NearestInpainter(n_jobs=1), ds, protocol="rect-v1", progress=False)
    assert res.meta["input_kind"] == "map"
    for row in res.rows:
        assert row["input_kind"] == "map"
        for m in ("rmse", "mae", "psnr", "count"):
            assert row[f"unmeasured_{m}"] == row[f"hole_{m}"]
        assert row["kitti_rmse"] == pytest.approx(1000 * row["all_rmse"], rel=1e-12)


def test_rows_survive_a_json_round_trip(scans, tmp_path):
    from inpaintenv.report.results import EvaluationResult

    res = evaluate(NearestInpainter(n_jobs=1), scans, protocol="densify-v1", n_frames=2, progress=False)
    back = EvaluationResult.from_json(res.to_json(tmp_path / "results.json"))
    assert json.dumps(back.rows, sort_keys=True) == json.dumps(res.rows, sort_keys=True)
    assert back.rows[0]["input_kind"] == "scan" and isinstance(back.rows[0]["unmeasured_count"], int)


def test_a_scan_run_and_a_map_run_have_different_run_keys(scans):
    maps = SyntheticStreets(n=4, seed=2, frame_shape=SHAPE, frames_per_drive=2)
    scan_key, map_key = fingerprint(scans, 4, ["rect-v1"], [0]), fingerprint(maps, 4, ["rect-v1"], [0])
    assert scan_key != map_key and "input_kind" not in map_key
    assert any("the input" in d for d in differences(map_key, scan_key))
    # A subset of a scan source (e.g. --drives) keeps the kind in its description too.
    assert "input='scan'" in repr(scans[[0, 1]])


def test_the_dask_path_scores_scans_like_a_local_run(scans):
    distributed = pytest.importorskip("distributed")
    kw = {"protocol": "rect-v1", "seeds": [0], "batch_size": 2, "progress": False}
    with distributed.LocalCluster(n_workers=1, processes=False, dashboard_address=":0") as local, \
            distributed.Client(local) as client:
        dist = evaluate(NearestInpainter(n_jobs=1), scans, client=client, **kw)
    serial = evaluate(NearestInpainter(n_jobs=1), scans, **kw)
    strip = [{k: v for k, v in r.items() if k != "ms"} for r in serial.rows]
    assert json.dumps([{k: v for k, v in r.items() if k != "ms"} for r in dist.rows]) == json.dumps(strip)
    assert all(r["input_kind"] == "scan" for r in dist.rows)


@pytest.mark.kitti
@pytest.mark.parametrize("protocol", ["densify-v1", "rect-v1"])
def test_official_val_selection_scans(kitti_root, protocol):
    ds = KittiDepth(kitti_root, split="val_selection", input="scan")
    res = evaluate(NearestInpainter(n_jobs=1), ds, protocol=protocol, progress=False)
    assert len(res.rows) == len(ds)
    for row in res.rows:
        assert row["input_kind"] == "scan" and row["unmeasured_count"] > row["hole_count"]
        # The scan covers about 5 % of the pixels: most ground truth is unmeasured.
        assert row["unmeasured_count"] > 0.5 * row["all_count"]
        assert 0 < row["unmeasured_rmse"] < 20 and row["kitti_rmse"] == pytest.approx(1000 * row["all_rmse"])


def test_cli_evaluate_input_scan(tmp_path):
    from inpaintenv.cli import main
    from inpaintenv.report.results import EvaluationResult
    from inpaintenv.report.tables import summary_table

    args = ["evaluate", "-m", "nearest", "--input", "scan", "--protocol", "densify-v1", "--synthetic",
            "--n-frames", "2", "--frame-shape", *map(str, SHAPE), "-q", "--out", str(tmp_path / "out")]
    assert main(args) == 0
    res = EvaluationResult.from_json(tmp_path / "out" / "results.json")
    assert res.meta["input_kind"] == "scan" and {r["input_kind"] for r in res.rows} == {"scan"}
    # Under densify-v1 a frame counts in the table's means by its unmeasured pixels, not its empty hole.
    entry = summary_table(res)[0]
    assert entry["n_skipped_hole"] == 0 and entry["all_rmse_n"] == 2 and np.isfinite(entry["all_rmse_low"])


class BrokenScan(SyntheticStreets):
    """Scans whose frame 1 cannot be read."""

    def _load_pair(self, index):
        if index == 1:
            raise OSError("scan of frame 1 is unreadable")
        return super()._load_pair(index)


def test_an_unreadable_scan_is_skipped_and_the_others_keep_their_own_scans():
    kw = {"n": 3, "seed": 2, "frame_shape": SHAPE, "frames_per_drive": 2, "input": "scan"}
    res = evaluate(NearestInpainter(n_jobs=1), BrokenScan(**kw), batch_size=3, on_bad_frame="skip", progress=False)
    clean = evaluate(NearestInpainter(n_jobs=1), SyntheticStreets(**kw), indices=[0, 2], progress=False)
    assert [r["index"] for r in res.meta["skipped_frames"]] == [1]
    assert json.dumps(_without_ms(res.rows)) == json.dumps(_without_ms(clean.rows))


def _without_ms(rows):
    return [{k: v for k, v in r.items() if k != "ms"} for r in rows]


class BandFill:
    """Nearest fill with a fixed +-1 m interval at every pixel to fill."""

    def predict(self, x: np.ndarray) -> np.ndarray:
        return NearestInpainter(n_jobs=1).predict(x)

    def predict_interval(self, x: np.ndarray, coverage: float = 0.9) -> tuple[np.ndarray, np.ndarray]:
        pred = self.predict(x)
        return np.maximum(pred - 1.0, 0.0), pred + 1.0


@pytest.mark.parametrize("protocol", ["densify-v1", "rect-v1"])
def test_interval_columns_score_the_task_pixels(scans, protocol):
    from inpaintenv.metrics import interval_metrics

    res = evaluate(BandFill(), scans, protocol=protocol, seeds=[0], batch_size=4, progress=False, intervals=0.9)
    inputs, gt = scans.load_pairs(range(len(scans)))
    hole = get_protocol(protocol).masks(SHAPE, 0, range(len(scans)))
    x = method_input(inputs, hole, "scan")
    pred = BandFill().predict(x)
    # densify-v1 cuts no hole: its task is every pixel the scan did not measure.
    scored = np.isnan(x) if protocol == "densify-v1" else hole
    want = interval_metrics(pred, gt, scored, *BandFill().predict_interval(x))
    for k, row in enumerate(res.rows):
        for key in ("hole_coverage", "hole_interval_width", "rmse_keep_80", "border_rmse_keep_80"):
            np.testing.assert_equal(row[key], want[key][k])
    assert np.isfinite([r["hole_coverage"] for r in res.rows]).any()
