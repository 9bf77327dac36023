"""Tests of inpaintenv.evaluate: scoring any callable or estimator on seeded (frame, mask) pairs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from inpaintenv.data import ArrayDataset, DepthDataset
from inpaintenv.evaluate import evaluate
from inpaintenv.report.results import EvaluationResult
from inpaintenv.exceptions import MethodOutputError
from inpaintenv.masks import get_protocol
from inpaintenv.methods.calls import method_name
from inpaintenv.metrics import frame_metrics


@pytest.fixture
def gt_ds(small_gt) -> ArrayDataset:
    return ArrayDataset(small_gt, groups=["a", "a", "b"])


def oracle_for(dataset):
    """A method that knows the ground truth: fills each hole perfectly."""
    frames = np.asarray(dataset)

    def oracle(x):
        # Identify the frame by its observed pixels.
        for f in frames:
            obs = ~np.isnan(x)
            if np.array_equal(x[obs], f[obs]):
                return f.copy()
        raise AssertionError("frame not found")

    return oracle


def test_perfect_method_scores_zero(gt_ds):
    res = evaluate(oracle_for(gt_ds), gt_ds, seeds=(0, 1), progress=False)
    (row,) = res.table
    assert row["hole_rmse"] == 0.0
    assert row["all_rmse"] == 0.0
    assert row["n_frames"] == 6
    assert len(res.rows) == 6
    assert {r["seed"] for r in res.rows} == {0, 1}


def test_constant_method_matches_hand_computation(gt_ds):
    c = 7.5
    res = evaluate(lambda x: np.where(np.isnan(x), c, x), gt_ds, progress=False, name="const")
    proto = get_protocol("rect-v1")
    per_frame_rmse, per_frame_mae = [], []
    for i in range(len(gt_ds)):
        gt = gt_ds[i]
        hole = proto.mask(gt.shape, 0, i)
        sel = hole & (gt > 0)
        err = c - gt[sel].astype(np.float64)
        per_frame_rmse.append(math.sqrt(float((err**2).mean())))
        per_frame_mae.append(float(np.abs(err).mean()))
    (row,) = res.table
    assert row["method"] == "const"
    assert row["hole_rmse"] == pytest.approx(np.mean(per_frame_rmse), rel=1e-6)
    assert row["hole_mae"] == pytest.approx(np.mean(per_frame_mae), rel=1e-6)
    # Observed pixels were returned unchanged, so the error outside holes is 0 and the
    # all-pixel squared error is the hole's share of it.
    for r, rmse in zip(res.rows, per_frame_rmse):
        assert r["all_rmse"] == pytest.approx(rmse * math.sqrt(r["hole_count"] / r["all_count"]), rel=1e-5)


def test_masks_reproducible_and_seed_dependent(gt_ds):
    seen = []

    def spy(x):
        seen.append(np.isnan(x).copy())
        return np.nan_to_num(x, nan=1.0)

    evaluate(spy, gt_ds, seeds=(3,), progress=False)
    first = list(seen)
    seen.clear()
    evaluate(spy, gt_ds, seeds=(3,), progress=False, batch_size=1)
    proto = get_protocol("rect-v1")
    for i, (a, b) in enumerate(zip(first, seen)):
        np.testing.assert_array_equal(a, b)
        np.testing.assert_array_equal(a, proto.mask(gt_ds.frame_shape, 3, i))
    seen.clear()
    evaluate(spy, gt_ds, seeds=(4,), progress=False)
    assert any(not np.array_equal(a, b) for a, b in zip(first, seen))


def test_rows_match_frame_metrics(gt_ds):
    res = evaluate(lambda x: np.nan_to_num(x, nan=20.0), gt_ds, seeds=(0,), progress=False)
    proto = get_protocol("rect-v1")
    for r in res.rows:
        gt = gt_ds[r["index"]]
        hole = proto.mask(gt.shape, 0, r["index"])
        m = frame_metrics(np.where(hole, 20.0, gt), gt, hole)
        assert r["hole_rmse"] == pytest.approx(float(m["hole_rmse"]))
        assert r["hole_fraction"] == pytest.approx(hole.mean())
        assert r["frame_id"] == gt_ds.frame_ids[r["index"]]
        assert r["drive"] == gt_ds.groups[r["index"]]
        assert r["ms"] >= 0


def test_skipped_frames_not_in_mean():
    frames = np.full((3, 24, 40), 10.0, dtype=np.float32)
    frames[1] = 0.0  # no ground truth at all -> hole holds none
    res = evaluate(lambda x: np.nan_to_num(x, nan=12.0), frames, progress=False)
    (row,) = res.table
    assert row["n_frames"] == 3
    assert row["n_skipped_hole"] == 1
    assert row["hole_rmse"] == pytest.approx(2.0)
    assert math.isnan(res.rows[1]["hole_rmse"])


def test_all_frames_skipped_gives_nan_not_zero():
    frames = np.zeros((2, 24, 40), dtype=np.float32)
    res = evaluate(lambda x: np.nan_to_num(x, nan=1.0), frames, progress=False)
    (row,) = res.table
    assert row["n_skipped_hole"] == 2
    assert math.isnan(row["hole_rmse"])
    assert "–" in res.to_markdown()


def test_batched_callable_and_predict_object(gt_ds):
    calls = []

    def batched(x):
        calls.append(x.shape)
        return np.nan_to_num(x, nan=5.0)

    batched.batched = True

    class Est:
        def predict(self, x):
            calls.append(x.shape)
            return np.nan_to_num(x, nan=5.0)

    a = evaluate(batched, gt_ds, batch_size=2, progress=False)
    assert calls == [(2, 32, 48), (1, 32, 48)]
    b = evaluate(Est(), gt_ds, batch_size=4, progress=False)
    assert calls[-1] == (3, 32, 48)
    assert a.table[0]["hole_rmse"] == pytest.approx(b.table[0]["hole_rmse"])
    assert b.table[0]["method"] == "Est"


def test_warm_up_call_is_untimed_and_can_be_turned_off(gt_ds):
    import time

    calls = []

    def slow_first_call(x):
        calls.append(x.shape)
        if len(calls) == 1:
            time.sleep(0.4)  # one-time start-up, e.g. torch's first call
        return np.nan_to_num(x, nan=5.0)

    warmed = evaluate(slow_first_call, gt_ds, seeds=[0, 1], progress=False, warmup=True)
    assert calls == [(32, 48)] * (1 + 2 * len(gt_ds))  # one warm-up call for the whole run
    calls.clear()
    cold = evaluate(slow_first_call, gt_ds, seeds=[0, 1], progress=False)  # off by default
    assert len(calls) == 2 * len(gt_ds)
    # ms is per frame of a batch of 4: the start-up adds 100 ms to the first batch's frames
    assert cold.rows[0]["ms"] >= 100.0 > max(r["ms"] for r in warmed.rows) + 50.0
    strip = lambda rows: [{k: v for k, v in r.items() if k != "ms"} for r in rows]
    assert strip(warmed.rows) == strip(cold.rows)


def test_warm_up_leaves_errors_to_the_timed_call(gt_ds):
    def broken(x):
        return np.zeros((3, 3), np.float32)

    with pytest.raises(MethodOutputError, match="broken"):
        evaluate(broken, gt_ds, progress=False, warmup=True)


def test_method_cannot_corrupt_later_frames_by_writing_input(gt_ds):
    def vandal(x):
        x[:] = 1.0
        return x

    ref = evaluate(lambda x: np.ones_like(x), gt_ds, progress=False)
    res = evaluate(vandal, gt_ds, progress=False)
    assert res.table[0]["all_rmse"] == pytest.approx(ref.table[0]["all_rmse"])


@pytest.mark.parametrize(
    "bad, match",
    [
        (lambda x: x, "NaN or inf"),
        (lambda x: np.zeros((3, 3)), "shape"),
        (lambda x: -np.ones_like(x), "negative"),
        (lambda x: np.full(x.shape, "a"), "dtype"),
        # One input rule everywhere: the env and the loader refuse these too.
        (lambda x: np.nan_to_num(x, nan=5.0).astype(np.uint8), "output has integer dtype uint8"),
        (lambda x: np.ma.masked_invalid(x).filled(5.0).view(np.ma.MaskedArray), "output is a numpy masked array"),
    ],
)
def test_bad_output_names_method(gt_ds, bad, match):
    with pytest.raises(MethodOutputError, match=match) as info:
        evaluate(bad, gt_ds, progress=False, name="badmethod")
    assert "badmethod" in str(info.value)


def test_unfilled_hole_pixels_are_refused_with_a_count(gt_ds):
    # nan_to_num(x, nan=0.0) was scored as 0 m without a word.
    with pytest.raises(MethodOutputError, match=r"^method 'zeros': prediction is 0 m \(unfilled\) at \d+ hole pixels with "
                                                r"ground truth; fill them, or set unfilled"):
        evaluate(lambda x: np.nan_to_num(x, nan=0.0), gt_ds, progress=False, name="zeros")
    with pytest.raises(ValueError, match="unfilled must be one of 'error', 'interpolate', 'zero'"):
        evaluate(lambda x: np.nan_to_num(x, nan=1.0), gt_ds, progress=False, unfilled=True)


def test_unfilled_policies_score_as_the_metrics_say(gt_ds):
    def zeros(x):
        return np.nan_to_num(x, nan=0.0)

    for policy in ("zero", "interpolate"):
        res = evaluate(zeros, gt_ds, seeds=[0, 1], progress=False, unfilled=policy)
        assert res.meta["unfilled"] == policy
        proto = get_protocol("rect-v1")
        for row in res.rows:
            gt = gt_ds[row["index"]]
            hole = proto.mask(gt.shape, row["seed"], row["index"])
            want = frame_metrics(zeros(np.where(hole, np.nan, gt)), gt, hole, unfilled=policy)
            assert row["hole_rmse"] == pytest.approx(float(want["hole_rmse"]))
    zero = evaluate(zeros, gt_ds, progress=False, unfilled="zero").table[0]
    ipol = evaluate(zeros, gt_ds, progress=False, unfilled="interpolate").table[0]
    assert ipol["hole_rmse"] < zero["hole_rmse"]
    assert evaluate(lambda x: np.nan_to_num(x, nan=1.0), gt_ds, progress=False).meta["unfilled"] == "error"


def test_bad_arguments(gt_ds):
    ok = lambda x: np.nan_to_num(x, nan=1.0)
    with pytest.raises(TypeError, match="callable"):
        evaluate(42, gt_ds)
    with pytest.raises(ValueError, match="n_frames"):
        evaluate(ok, gt_ds, n_frames=0)
    with pytest.raises(ValueError, match="seeds"):
        evaluate(ok, gt_ds, seeds=())
    with pytest.raises(ValueError, match="batch_size"):
        evaluate(ok, gt_ds, batch_size=0)
    with pytest.raises(KeyError, match="rect-v1"):
        evaluate(ok, gt_ds, protocol="no-such-protocol")


@pytest.mark.parametrize(
    "kwargs, error, match",
    [
        ({"seeds": "12"}, TypeError, "seeds must be distinct non-negative integers, got '12'"),
        ({"seeds": [0.5, 1.5]}, TypeError, "seeds must be distinct non-negative integers"),
        ({"seeds": 1.7}, TypeError, "seeds must be"),
        ({"seeds": [0, 0]}, ValueError, "repeated"),
        ({"seeds": -1}, ValueError, "seeds must be distinct non-negative integers, got -1"),
        ({"indices": [0, 0]}, ValueError, "indices must be distinct"),
        ({"indices": [0.9]}, TypeError, "indices must be"),
        ({"indices": [5]}, ValueError, "outside 0..2"),
        ({"n_frames": 1.5}, TypeError, "n_frames must be an integer, got 1.5"),
        ({"n_frames": "2"}, TypeError, "n_frames must be an integer, got '2'"),
        ({"batch_size": 1.5}, TypeError, "batch_size must be an integer"),
        ({"max_depth": float("nan")}, ValueError, "max_depth must be a finite positive number of metres, got nan"),
        ({"max_depth": "80"}, TypeError, "max_depth must be a finite positive number"),
    ],
)
def test_arguments_are_validated_not_coerced(gt_ds, kwargs, error, match):
    ok = lambda x: np.nan_to_num(x, nan=1.0)
    with pytest.raises(error, match=match):
        evaluate(ok, gt_ds, progress=False, **kwargs)


def test_numpy_integer_seeds_and_indices_are_fine(gt_ds):
    res = evaluate(lambda x: np.nan_to_num(x, nan=1.0), gt_ds, seeds=np.array([3, 1]),
                   indices=[np.int64(2)], progress=False)
    assert [(r["seed"], r["index"]) for r in res.rows] == [(3, 2), (1, 2)]
    assert all(type(r["seed"]) is int for r in res.rows)


def test_channel_axis_source_is_refused(small_gt):
    # (H, W, 1) used to be scored as H frames of width 1.
    with pytest.raises(ValueError, match="trailing size-1 axis looks like a channel axis"):
        evaluate(lambda x: np.nan_to_num(x, nan=1.0), small_gt[0][..., None], progress=False)


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.int64])
def test_integer_source_is_refused_like_an_8bit_png(small_gt, dtype):
    # An 8-bit (N, H, W) source used to be scored (hole RMSE 92.2); the loader refuses 8-bit PNGs.
    with pytest.raises(TypeError, match=f"frames has integer dtype {np.dtype(dtype).name}; depth is floating-point"):
        evaluate(lambda x: np.nan_to_num(x, nan=1.0), np.rint(small_gt).astype(dtype), progress=False)


def test_masked_source_is_refused(small_gt):
    with pytest.raises(TypeError, match="frames is a numpy masked array"):
        evaluate(lambda x: np.nan_to_num(x, nan=1.0), np.ma.masked_equal(small_gt, 0.0), progress=False)


def test_raw_png_codes_are_refused(small_gt):
    raw = np.rint(small_gt * 256).astype(np.uint16)
    with pytest.raises(TypeError, match="integer dtype uint16.*divide by 256"):
        evaluate(lambda x: np.nan_to_num(x, nan=1.0), raw, progress=False)
    with pytest.raises(ValueError, match="divide by 256"):
        evaluate(lambda x: np.nan_to_num(x, nan=1.0), raw.astype(np.float32), progress=False)


class _Unchecked(DepthDataset):
    """A custom dataset serving frames as given (ArrayDataset would check them)."""

    def __init__(self, frames):
        self._frames = frames
        self.frame_shape = frames.shape[1:]
        self.groups = np.asarray([f"d{i}" for i in range(len(frames))])
        self.frame_ids = [f"d{i}/0" for i in range(len(frames))]

    def _load(self, index):
        return self._frames[index]


def test_bad_ground_truth_is_blamed_on_the_data_not_the_method(small_gt):
    bad = small_gt.copy()
    bad[1, 0, 0] = -3.0
    with pytest.raises(ValueError, match=r"frame 1 \(d1/0\) contains negative depth") as info:
        evaluate(lambda x: np.nan_to_num(x, nan=1.0), _Unchecked(bad), progress=False)
    assert not isinstance(info.value, MethodOutputError)


def test_n_frames_and_by_drive(gt_ds):
    res = evaluate(lambda x: np.nan_to_num(x, nan=9.0), gt_ds, n_frames=2, progress=False)
    assert [r["index"] for r in res.rows] == [0, 1]
    res = evaluate(lambda x: np.nan_to_num(x, nan=9.0), gt_ds, seeds=(0, 1), progress=False)
    drives = res.by_drive()
    assert [(d["drive"], d["n_frames"]) for d in drives] == [("a", 4), ("b", 2)]
    rows_a = [r["hole_rmse"] for r in res.rows if r["drive"] == "a"]
    assert drives[0]["hole_rmse"] == pytest.approx(np.mean(rows_a))
    assert [s["seed"] for s in res.by_seed()] == [0, 1]
    assert "drive" in res.to_markdown(drives)


def test_json_csv_round_trip(gt_ds, tmp_path):
    frames = np.asarray(gt_ds).copy()
    frames[2] = 0.0  # one skipped frame, so NaN has to survive the round trip
    res = evaluate(lambda x: np.nan_to_num(x, nan=9.0), frames, seeds=(0, 2), progress=False)
    back_json = EvaluationResult.from_json(res.to_json(tmp_path / "r.json"))
    back_csv = EvaluationResult.from_csv(res.to_csv(tmp_path / "r.csv"))
    for back in (back_json, back_csv):
        assert len(back.rows) == len(res.rows)
        for a, b in zip(res.rows, back.rows):
            assert a.keys() == b.keys()
            for k in a:
                if isinstance(a[k], float) and math.isnan(a[k]):
                    assert math.isnan(b[k])
                elif isinstance(a[k], float):
                    assert b[k] == pytest.approx(a[k], rel=1e-12)
                else:
                    assert b[k] == a[k] and type(b[k]) is type(a[k])
        assert back.table[0]["hole_rmse"] == pytest.approx(res.table[0]["hole_rmse"])
    assert back_json.meta["seeds"] == [0, 2]


def test_concat_and_markdown(gt_ds):
    a = evaluate(lambda x: np.nan_to_num(x, nan=9.0), gt_ds, progress=False, name="nine")
    b = evaluate(lambda x: np.nan_to_num(x, nan=20.0), gt_ds, progress=False, name="twenty")
    c = evaluate(lambda x: np.nan_to_num(x, nan=9.0), gt_ds, protocol="freeform-v1", seeds=(1,),
                 progress=False, name="nine")
    both = EvaluationResult.concat([a, b])
    assert both.methods == ["nine", "twenty"]
    mixed = EvaluationResult.concat([a, c])
    assert mixed.meta["protocol"] == ["rect-v1", "freeform-v1"] and mixed.meta["seeds"] == [0, 1]
    assert [(t["method"], t["protocol"]) for t in mixed.table] == [("nine", "rect-v1"), ("nine", "freeform-v1")]
    with pytest.raises(ValueError, match="no results"):
        EvaluationResult.concat([])
    md = both.to_markdown().splitlines()
    assert md[0].startswith("| method |") and md[4] == ""  # header, rule, two rows, then the notes
    assert "| nine |" in md[2] and "| twenty |" in md[3]


def test_method_name():
    def fill(x):
        return x

    class M:
        def predict(self, x):
            return x

    assert method_name(fill) == "fill"
    assert method_name(M()) == "M"
    assert method_name(lambda x: x) == "lambda"


def test_default_source_is_synthetic():
    res = evaluate(lambda x: np.nan_to_num(x, nan=10.0), None, n_frames=2, progress=False)
    assert res.table[0]["n_frames"] == 2
    assert "SyntheticStreets" in res.meta["source"]


def test_never_imports_estimators_or_torch():
    import subprocess
    import sys

    code = (
        "import sys, inpaintenv, inpaintenv.evaluate; "
        "bad = [m for m in ('torch', 'estimators') if m in sys.modules]; "
        "assert not bad, bad"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_env_as_source(gt_ds):
    import gymnasium as gym

    env = gym.make("inpaintenv/DepthInpaint-v0", dataset=gt_ds)
    a = evaluate(lambda x: np.nan_to_num(x, nan=9.0), env, progress=False)
    b = evaluate(lambda x: np.nan_to_num(x, nan=9.0), gt_ds, progress=False)
    strip = lambda rows: [{k: v for k, v in r.items() if k != "ms"} for r in rows]
    assert strip(a.rows) == strip(b.rows)


def test_env_serves_the_pairs_evaluate_scores(gt_ds):
    """reset(options={"index": i, "mask_seed": s}) + step gives evaluate's row for (s, i)."""
    from inpaintenv.envs import DepthInpaintEnv

    fill = lambda x: np.nan_to_num(x, nan=9.0)
    res = evaluate(fill, gt_ds, seeds=(4,), progress=False)
    env = DepthInpaintEnv(gt_ds)
    for row in res.rows:
        obs, _ = env.reset(options={"index": row["index"], "mask_seed": 4})
        action = np.where(obs["hole"].astype(bool), 9.0, obs["depth"]).astype(np.float32)
        _, reward, *_ , info = env.step(action)
        assert reward == pytest.approx(-row["hole_rmse"])
        assert info["all_rmse"] == pytest.approx(row["all_rmse"])


def test_run_method_validates_and_times():
    from inpaintenv.methods.calls import run_method

    x = np.full((2, 8, 10), 5.0, np.float32)
    x[:, 2:4, 3:6] = np.nan
    pred, ms = run_method(lambda f: np.nan_to_num(f, nan=5.0), x)
    assert pred.shape == x.shape and (pred == 5.0).all() and ms >= 0
    with pytest.raises(MethodOutputError, match="'hole-left'"):
        run_method(lambda f: f, x, name="hole-left")
    with pytest.raises(ValueError, match="batch"):
        run_method(lambda f: f, x[0])
    with pytest.raises(ValueError, match="no frames"):
        run_method(lambda f: f, np.zeros((0, 4, 4), np.float32))


class _FakeTTY:
    """A stderr stand-in that claims to be a terminal and records what is written."""

    def __init__(self):
        self.text = ""

    def write(self, s):
        self.text += s
        return len(s)

    def flush(self):
        pass

    def isatty(self):
        return True


@pytest.mark.parametrize("progress", [True, False])
def test_progress_bar_on_terminal_only_when_asked(monkeypatch, progress):
    fake = _FakeTTY()
    monkeypatch.setattr("sys.stderr", fake)
    evaluate(lambda x: np.nan_to_num(x, nan=1.0), np.ones((3, 16, 20), np.float32), progress=progress,
             name="bar")
    assert ("evaluate bar" in fake.text) is progress


def test_output_above_the_env_bound_is_refused_with_the_env_s_words():
    # evaluate scored reconstructions above 255.996 m that the environment refuses.
    from inpaintenv.envs import DepthInpaintEnv

    gt = np.full((2, 32, 48), 10.0, dtype=np.float32)
    too_deep = lambda x: np.nan_to_num(x, nan=300.0)  # noqa: E731
    with pytest.raises(MethodOutputError, match=r"method 'deep': output has depth up to 300 m, above the bound 255.996 m"):
        evaluate(too_deep, gt, progress=False, name="deep")
    env = DepthInpaintEnv(gt)
    obs, _ = env.reset(seed=0)
    with pytest.raises(ValueError) as from_env:
        env.step(too_deep(np.where(obs["hole"] == 1, np.nan, obs["depth"])))
    with pytest.raises(MethodOutputError) as from_evaluate:
        evaluate(too_deep, gt, progress=False, name="deep")
    assert str(from_env.value).removeprefix("action ") == str(from_evaluate.value).removeprefix("method 'deep': output ")


# ---------------------------------------------------------------------------------------
# Per-pixel intervals (evaluate(..., intervals=coverage))
# ---------------------------------------------------------------------------------------
class _TruthPlusMinusOne:
    """Knows the truth (fills it) and gives the interval truth ± 1 m: coverage 1.0."""

    def __init__(self, dataset):
        self.fill = oracle_for(dataset)

    def predict(self, x):
        return np.stack([self.fill(f) for f in x]).astype(np.float32)

    def predict_interval(self, x, coverage=0.9):
        self.coverage_asked = coverage
        p = self.predict(x)
        return np.maximum(p - 1.0, 0.0), p + 1.0


class _ConstantStd:
    """scikit-learn's return_std protocol: predict(X, return_std=True) -> (pred, std)."""

    def predict(self, x, return_std=False):
        pred = np.nan_to_num(x, nan=12.0).astype(np.float32)
        return (pred, np.full_like(pred, 2.0)) if return_std else pred


def _fill_12(x):
    return np.nan_to_num(x, nan=12.0)


def test_interval_around_the_truth_has_coverage_one(gt_ds):
    method = _TruthPlusMinusOne(gt_ds)
    res = evaluate(method, gt_ds, intervals=0.8, progress=False)
    assert method.coverage_asked == 0.8
    assert res.meta["interval_coverage"] == 0.8 and res.meta["interval_methods"] == ["_TruthPlusMinusOne"]
    for row in res.rows:
        assert row["hole_coverage"] == 1.0
        assert row["hole_rmse"] == 0.0 and math.isnan(row["rejection_auc"])  # a perfect fill has no curve
    assert res.table[0]["hole_coverage"] == 1.0


def test_interval_columns_equal_a_numpy_recomputation(gt_ds):
    from statistics import NormalDist

    res = evaluate(_ConstantStd(), gt_ds, intervals=0.9, progress=False, batch_size=2)
    z = NormalDist().inv_cdf(0.95)
    proto = get_protocol("rect-v1")
    for row in res.rows:
        gt = np.asarray(gt_ds)[row["index"]]
        hole = proto.mask(gt.shape, row["seed"], row["index"])
        pred = np.where(hole, 12.0, gt)
        low, high = np.maximum(pred - 2 * z, 0), pred + 2 * z
        covered, widths = [], []
        for y, x in zip(*np.nonzero(hole & (gt > 0))):
            covered.append(low[y, x] <= gt[y, x] <= high[y, x])
            widths.append(high[y, x] - low[y, x])
        assert row["hole_coverage"] == pytest.approx(np.mean(covered), abs=1e-12)
        assert row["hole_interval_width"] == pytest.approx(np.mean(widths), rel=1e-6)


def test_methods_without_intervals_keep_their_rows_bit_identical(gt_ds):
    plain = evaluate(_fill_12, gt_ds, progress=False)
    asked = evaluate(_fill_12, gt_ds, intervals=0.9, progress=False)
    strip = [{k: v for k, v in r.items() if k != "ms"} for r in plain.rows]
    assert [{k: v for k, v in r.items() if k != "ms"} for r in asked.rows] == strip
    assert asked.meta["interval_methods"] == []
    # The return_std method's prediction and rows are those of its plain predict.
    std_rows = evaluate(_ConstantStd(), gt_ds, intervals=0.9, progress=False).rows
    assert [{k: r[k] for k in strip[0] if k != "method"} for r in std_rows] == [
        {k: v for k, v in r.items() if k != "method"} for r in strip
    ]
    # Without intervals= nothing is asked and no column appears.
    assert "hole_coverage" not in evaluate(_TruthPlusMinusOne(gt_ds), gt_ds, progress=False).rows[0]


def test_mixed_table_shows_a_dash_for_the_method_without_intervals(gt_ds, tmp_path):
    both = EvaluationResult.concat([
        evaluate(_ConstantStd(), gt_ds, intervals=0.9, progress=False, name="std"),
        evaluate(_fill_12, gt_ds, intervals=0.9, progress=False, name="plain"),
    ])
    md = both.to_markdown()
    assert "hole coverage" in md
    plain_line = next(line for line in md.splitlines() if line.startswith("| plain"))
    from inpaintenv.metrics import metric_records

    assert plain_line.count("| – ") == len(metric_records("interval"))  # every interval column of the table
    assert "Per-pixel intervals:" in md  # the note under the table explains the columns
    plain_md = evaluate(_fill_12, gt_ds, progress=False).to_markdown()
    assert "hole coverage" not in plain_md and "Per-pixel intervals:" not in plain_md
    back = EvaluationResult.from_csv(both.to_csv(tmp_path / "rows.csv"))
    assert back.rows[0]["rmse_keep_80"] == both.rows[0]["rmse_keep_80"]


class _BadInterval(_ConstantStd):
    def __init__(self, make):
        self.make = make

    def predict_interval(self, x, coverage=0.9):
        return self.make(self.predict(x))


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda p: (p + 1, p - 1), "inverted"),
        (lambda p: (p * np.nan, p), "NaN"),
        (lambda p: (p + 0.5, p + 1), "does not hold the prediction"),
        (lambda p: (p[:, :-1], p[:, :-1]), "shape"),
        (lambda p: p, r"\(low, high\)"),
    ],
)
def test_bad_interval_is_refused_naming_the_method(gt_ds, make, message):
    with pytest.raises(MethodOutputError, match=rf"'bad'.*{message}|{message}.*'bad'"):
        evaluate(_BadInterval(make), gt_ds, intervals=0.9, progress=False, name="bad")


@pytest.mark.parametrize("coverage", [0, 1, 1.2, "0.9", True])
def test_bad_interval_coverage_is_refused(gt_ds, coverage):
    with pytest.raises((ValueError, TypeError), match="intervals"):
        evaluate(_fill_12, gt_ds, intervals=coverage, progress=False)


def test_concat_merges_the_methods_that_gave_intervals(gt_ds):
    both = EvaluationResult.concat([
        evaluate(_fill_12, gt_ds, intervals=0.9, progress=False, name="plain"),
        evaluate(_ConstantStd(), gt_ds, intervals=0.9, progress=False, name="std"),
    ])
    assert both.meta["interval_methods"] == ["std"] and both.meta["interval_coverage"] == 0.9


def test_cli_evaluate_interval_coverage(tmp_path, monkeypatch, capsys):
    from inpaintenv.cli import main

    (tmp_path / "bandmod.py").write_text(
        "import numpy as np\n"
        "class Band:\n"
        "    def predict(self, x):\n"
        "        return np.nan_to_num(x, nan=12.0).astype(np.float32)\n"
        "    def predict_interval(self, x, coverage=0.9):\n"
        "        p = self.predict(x)\n"
        "        return np.maximum(p - 4.0, 0.0), p + 4.0\n"
    )
    monkeypatch.chdir(tmp_path)
    argv = ["evaluate", "-m", "bandmod:Band", "-m", "nearest", "--n-frames", "2", "--frame-shape", "64", "96", "-q"]
    assert main([*argv, "--interval-coverage", "0.9"]) == 0
    out = capsys.readouterr().out
    assert "hole coverage" in out and "8.00" in out  # the width of ± 4 m
    assert main([*argv, "--interval-coverage", "90"]) == 1
    assert "--interval-coverage" in capsys.readouterr().err


def test_integer_interval_is_refused_naming_the_method(gt_ds):
    method = _BadInterval(lambda p: (np.zeros(p.shape, np.int32), np.ones(p.shape, np.int32)))
    with pytest.raises(MethodOutputError, match="'bad'"):
        evaluate(method, gt_ds, intervals=0.9, progress=False, name="bad")
