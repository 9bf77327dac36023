"""ConformalIntervalInpainter: drive-grouped conformal intervals around a fitted inpainter."""

from __future__ import annotations

import json

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.model_selection import GridSearchCV

from estimators.classical import ScanlineInpainter
from estimators.base import iter_scoring_batches
from estimators.intervals import ConformalIntervalInpainter
from inpaintenv.data import ArrayDataset
from inpaintenv.evaluate import evaluate
from inpaintenv.exceptions import InvalidInputError, InvalidTypeError

from stand_ins import FillTen, FoldTen
from streets import streets

H, W = 64, 96


def iid_frames(n: int, seed: int) -> np.ndarray:
    """Exchangeable truth: every pixel 10 m plus independent noise, so split conformal is exact."""
    rng = np.random.default_rng(seed)
    return np.clip(10.0 + 2.0 * rng.standard_normal((n, H, W)), 0.1, None).astype(np.float32)


def drives(n: int, prefix: str = "d") -> list[str]:
    return [f"{prefix}{k // 2}" for k in range(n)]


@pytest.fixture(scope="module")
def street_wrapper() -> ConformalIntervalInpainter:
    frames = streets(6, h=H, w=W, seed=1)
    return ConformalIntervalInpainter(ScanlineInpainter(), spread_method="nearest").fit(frames, groups=drives(6))


@pytest.fixture(scope="module")
def street_input() -> np.ndarray:
    x, _, _ = next(iter_scoring_batches(streets(3, h=H, w=W, seed=7), seed=3))
    return x


def test_interval_holds_prediction_positive_width_in_hole_zero_outside(street_wrapper, street_input):
    x = street_input
    pred = street_wrapper.predict(x)
    low, high = street_wrapper.predict_interval(x)
    hole = np.isnan(x)
    assert low.shape == high.shape == x.shape
    assert np.isfinite(low).all() and np.isfinite(high).all()
    assert (low >= 0).all() and (low <= pred).all() and (pred <= high).all()  # never inverted, holds pred
    assert (high[hole] - low[hole] > 0).all() and (high[hole] > 0).all()
    np.testing.assert_array_equal(low[~hole], pred[~hole])
    np.testing.assert_array_equal(high[~hole], pred[~hole])


def test_single_frame_gives_single_frame_interval(street_wrapper, street_input):
    low, high = street_wrapper.predict_interval(street_input[0])
    low3, high3 = street_wrapper.predict_interval(street_input)
    assert low.shape == street_input[0].shape
    np.testing.assert_array_equal(high, high3[0])


def test_return_std_leaves_prediction_bit_identical(street_wrapper, street_input):
    plain = street_wrapper.predict(street_input)
    pred, std = street_wrapper.predict(street_input, return_std=True)
    np.testing.assert_array_equal(pred, plain)
    np.testing.assert_array_equal(plain, ScanlineInpainter().predict(street_input))
    hole = np.isnan(street_input)
    assert (std[hole] > 0).all() and (std[~hole] == 0).all() and np.isfinite(std).all()


def test_std_is_the_calibrated_interval_over_z(street_wrapper, street_input):
    pred, std = street_wrapper.predict(street_input, return_std=True)
    low, high = street_wrapper.predict_interval(street_input)
    np.testing.assert_allclose(high - pred, 1.6448536269514722 * std, rtol=1e-5, atol=1e-5)


def test_wider_coverage_is_wider(street_input):
    # Noisy truth: scanline is near exact on the streets, where every width is float32's floor.
    wrapper = ConformalIntervalInpainter(FillTen(), signals=("border", "depth")).fit(iid_frames(6, seed=0),
                                                                                  groups=drives(6))
    lo5, hi5 = wrapper.predict_interval(street_input, coverage=0.5)
    lo9, hi9 = wrapper.predict_interval(street_input, coverage=0.9)
    lo99, hi99 = wrapper.predict_interval(street_input, coverage=0.99)
    assert (hi5 <= hi9).all() and (hi9 <= hi99).all() and (hi99 - lo99).sum() > (hi5 - lo5).sum()


def test_coverage_near_nominal_on_exchangeable_data():
    cal, test = iid_frames(20, seed=0), iid_frames(40, seed=1)
    wrapper = ConformalIntervalInpainter(FillTen(), signals=("border", "depth")).fit(cal, groups=drives(20))
    covered = total = 0
    for x, gt, hole in iter_scoring_batches(test, seed=5):
        low, high = wrapper.predict_interval(x)
        scored = hole & (gt > 0)
        covered += int(((gt >= low) & (gt <= high))[scored].sum())
        total += int(scored.sum())
    assert total > 30_000
    assert abs(covered / total - 0.9) < 0.03
    # Another coverage from the stored quantiles holds as well.
    lo, hi = wrapper.predict_interval(x, coverage=0.5)
    assert abs(((gt >= lo) & (gt <= hi))[scored].mean() - 0.5) < 0.06


def uneven_frames(n: int, seed: int) -> np.ndarray:
    """Truth whose noise grows from frame to frame: the frames differ in how hard they are."""
    rng = np.random.default_rng(seed)
    sd = np.linspace(0.2, 4.0, n)[:, None, None]
    return np.clip(10.0 + sd * rng.standard_normal((n, H, W)), 0.1, None).astype(np.float32)


def coverage_by_frame(wrapper, frames, seed=0) -> tuple[np.ndarray, float]:
    """Each frame's coverage of its hole, and the coverage of all hole pixels pooled."""
    per_frame, covered, total = [], 0, 0
    for x, gt, hole in iter_scoring_batches(frames, seed=seed):
        low, high = wrapper.predict_interval(x)
        inside = (gt >= low) & (gt <= high)
        for k in range(len(x)):
            scored = hole[k] & (gt[k] > 0)
            per_frame.append(inside[k][scored].mean())
            covered, total = covered + int(inside[k][scored].sum()), total + int(scored.sum())
    return np.asarray(per_frame), covered / total


def test_frame_weighting_calibrates_the_mean_over_frames_pixel_weighting_the_pooled_pixels():
    frames = uneven_frames(12, seed=0)
    by_frame = ConformalIntervalInpainter(FillTen(), signals=()).fit(frames, groups=drives(12))
    by_pixel = ConformalIntervalInpainter(FillTen(), signals=(), weighting="pixel").fit(frames, groups=drives(12))
    assert by_frame.calibration_["weighting"] == "frame" and by_pixel.calibration_["weighting"] == "pixel"
    per_frame, _ = coverage_by_frame(by_frame, frames)
    # On its own calibration frames the frame-weighted q gives a mean over frames of c (up to one pixel's share).
    assert abs(per_frame.mean() - 0.9) < 0.005
    _, pooled = coverage_by_frame(by_pixel, frames)
    assert pooled >= 0.9 and pooled - 0.9 < 0.005
    # The hole sizes differ, so the two quantiles differ.
    assert by_frame.quantile_ != by_pixel.quantile_


def test_weighted_quantiles_with_equal_weights_are_numpys_inverted_cdf():
    from estimators.intervals._conformal import weighted_quantiles

    values = np.random.default_rng(0).standard_normal(1001)
    levels = np.linspace(0.0, 1.0, 101)
    np.testing.assert_array_equal(weighted_quantiles(values, np.ones(values.size), levels),
                                  np.quantile(values, levels, method="inverted_cdf"))
    # One value carrying half the weight is the median.
    w = np.ones(values.size)
    w[17] = values.size - 1
    assert weighted_quantiles(values, w, [0.5])[0] <= values[17]


def test_files_without_weighting_load_as_pixel_weighted(street_wrapper, tmp_path):
    # Calibrations written before the frame weighting (the shipped v1 files) were by pixel.
    data = street_wrapper.to_dict("scanline")
    del data["params"]["weighting"], data["calibration"]["weighting"]
    (tmp_path / "old.json").write_text(json.dumps(data))
    old = ConformalIntervalInpainter.load(tmp_path / "old.json")
    assert old.weighting == "pixel" and old.calibration_["weighting"] == "pixel"
    assert old.quantile_ == street_wrapper.quantile_


def test_finite_sample_quantile_is_the_ceil_order_statistic():
    sorted_r = np.arange(1, 20, dtype=float)  # n = 19: ceil(20 * 0.9) = 18th smallest
    assert ConformalIntervalInpainter._exact_quantile(sorted_r, 0.9) == 18.0
    with pytest.raises(InvalidInputError, match="too few"):
        ConformalIntervalInpainter._exact_quantile(sorted_r[:5], 0.9)


def test_calibration_without_drive_ids_is_refused():
    with pytest.raises(InvalidInputError, match="drive ids"):
        ConformalIntervalInpainter(FillTen(), signals=()).fit(iid_frames(4, seed=0))
    with pytest.raises(InvalidInputError, match="one drive id per frame"):
        ConformalIntervalInpainter(FillTen(), signals=()).fit(iid_frames(4, seed=0), groups=["a"])


def test_calibration_records_what_it_was_calibrated_on():
    frames = iid_frames(4, seed=0)
    wrapper = ConformalIntervalInpainter(FillTen(), signals=("border",)).fit(ArrayDataset(frames, groups=drives(4)))
    cal = wrapper.calibration_
    assert cal["drives"] == ["d0", "d1"] and cal["n_frames"] == 4 and cal["coverage"] == 0.9
    assert cal["n_pixels"] == wrapper.n_calibration_pixels_ > 0 and cal["protocol"] == "rect-v1"


def test_drives_the_base_was_trained_on_are_refused():
    base = FillTen()
    base.training_drives_ = ["d1"]
    with pytest.raises(InvalidInputError, match=r"trained on calibration drives \['d1'\]"):
        ConformalIntervalInpainter(base, signals=()).fit(iid_frames(4, seed=0), groups=drives(4))


def test_spread_against_the_same_fill_is_refused():
    with pytest.raises(InvalidInputError, match="spread_method='scanline' fills as the base does"):
        ConformalIntervalInpainter(ScanlineInpainter()).fit(streets(2, h=H, w=W), groups=["a", "b"])


@pytest.mark.parametrize("params, match", [
    ({"coverage": 1.0}, "coverage"), ({"signals": ("width",)}, "signals"), ({"signals": "border"}, "signals"),
    ({"seed": -1}, "seed"), ({"protocol": "nope"}, "nope"), ({"weighting": "drive"}, "weighting"),
    ({"coverage": True}, r"^coverage must be a number in \(0, 1\), got True$"),
    ({"signals": ("border", "border")}, "^signals must be distinct names"),
    ({"estimator": object()}, r"^estimator must have predict\(X\), got object$"),
    ({"spread_method": 3}, "^spread_method must be a registered method name, got 3$"),
    ({"seed": 1.0}, "^seed must be an integer >= 0, got 1.0$"),
    ({"max_fit_pixels": 9}, "^max_fit_pixels must be an integer >= 10, got 9$"),
    ({"weighting": "drive"}, r"^weighting must be one of \('frame', 'pixel'\), got 'drive'$"),
])
def test_bad_parameters_named(params, match):
    params = {"estimator": FillTen(), **params}
    with pytest.raises((InvalidInputError, InvalidTypeError, KeyError), match=match):
        ConformalIntervalInpainter(**params).fit(iid_frames(2, seed=0), groups=["a", "b"])


def test_parameter_table_lists_every_parameter():
    table = ConformalIntervalInpainter._parameter_constraints
    assert set(table) == set(ConformalIntervalInpainter(FillTen()).get_params(deep=False))


def test_unfitted_wrapper_refuses_intervals():
    from sklearn.exceptions import NotFittedError

    with pytest.raises(NotFittedError):
        ConformalIntervalInpainter(FillTen()).predict_interval(iid_frames(1, seed=0))


def test_save_load_round_trip(street_wrapper, street_input, tmp_path):
    path = street_wrapper.save(tmp_path / "cal.json", base="scanline")
    assert path.stat().st_size < 100_000
    data = json.loads(path.read_text())
    assert data["base"] == "scanline" and data["calibration"] == street_wrapper.calibration_
    back = ConformalIntervalInpainter.load(path)  # base rebuilt from its registered name
    assert back.get_params(deep=False).keys() == street_wrapper.get_params(deep=False).keys()
    np.testing.assert_array_equal(back.coef_, street_wrapper.coef_)
    for a, b in zip(back.predict_interval(street_input, 0.8), street_wrapper.predict_interval(street_input, 0.8)):
        np.testing.assert_array_equal(a, b)
    assert back.calibration_ == street_wrapper.calibration_


def test_load_refuses_other_base_and_bad_files(street_wrapper, tmp_path):
    path = street_wrapper.save(tmp_path / "cal.json")
    with pytest.raises(InvalidInputError, match="calibrated for a ScanlineInpainter"):
        ConformalIntervalInpainter.load(path, estimator=FillTen())
    data = json.loads(path.read_text())
    del data["coef"]
    (tmp_path / "bad.json").write_text(json.dumps(data))
    with pytest.raises(InvalidInputError, match="bad.json.*'coef'"):
        ConformalIntervalInpainter.load(tmp_path / "bad.json", estimator=ScanlineInpainter())
    (tmp_path / "junk.json").write_text("{")
    with pytest.raises(InvalidInputError, match="junk.json"):
        ConformalIntervalInpainter.load(tmp_path / "junk.json")


def test_sklearn_clone_and_params():
    wrapper = ConformalIntervalInpainter(ScanlineInpainter(), coverage=0.8, signals=("depth",))
    twin = clone(wrapper)
    assert twin.get_params(deep=False)["coverage"] == 0.8 and twin.signals == ("depth",)
    assert "estimator__max_iter" in wrapper.get_params() or any(k.startswith("estimator__") for k in wrapper.get_params())
    twin.set_params(coverage=0.7, signals=())
    assert twin.coverage == 0.7 and wrapper.coverage == 0.8
    grid = GridSearchCV(wrapper, {"coverage": [0.8, 0.9]})
    assert clone(grid).estimator.coverage == 0.8


def test_evaluate_scores_the_wrapper_interval(street_wrapper):
    frames = streets(3, h=H, w=W, seed=11)
    result = evaluate(street_wrapper, frames, intervals=0.9, progress=False, name="conformal")
    assert all(np.isfinite(r["hole_coverage"]) and r["hole_interval_width"] > 0 for r in result.rows)
    # The benchmark's coverage is the NumPy one on the same (protocol, seed 0, index) holes.
    for row, (x, gt, hole) in zip(result.rows, (b for batch in iter_scoring_batches(frames, chunk=1)
                                               for b in [tuple(a for a in batch)])):
        low, high = street_wrapper.predict_interval(x)
        scored = hole & (gt > 0)
        assert row["hole_coverage"] == pytest.approx(((gt >= low) & (gt <= high))[scored].mean())


def test_std_keeps_the_calibrated_coverage_after_set_params(street_input):
    frames = streets(6, h=H, w=W, seed=1)
    wrapper = ConformalIntervalInpainter(ScanlineInpainter(), spread_method="nearest").fit(frames, groups=drives(6))
    _, std = wrapper.predict(street_input, return_std=True)
    wrapper.set_params(coverage=0.5)  # without a new fit, std still refers to the calibrated 0.9
    _, after = wrapper.predict(street_input, return_std=True)
    np.testing.assert_array_equal(after, std)
    low, high = wrapper.predict_interval(street_input)  # the new default coverage, from the stored quantiles
    np.testing.assert_array_equal(high, wrapper.predict_interval(street_input, coverage=0.5)[1])


def test_interval_keeps_the_calibrated_spread_fill_after_set_params(street_input, tmp_path):
    frames = streets(6, h=H, w=W, seed=1)
    wrapper = ConformalIntervalInpainter(ScanlineInpainter(), spread_method="nearest").fit(frames, groups=drives(6))
    before = wrapper.predict_interval(street_input)
    wrapper.set_params(spread_method="harmonic")
    np.testing.assert_array_equal(wrapper.predict_interval(street_input)[1], before[1])
    with pytest.raises(InvalidInputError, match="spread_method was set to 'harmonic' after calibrating"):
        wrapper.save(tmp_path / "cal.json")


@pytest.mark.kitti
def test_calibrated_on_one_day_scored_on_another_real_kitti(kitti_root):
    from inpaintenv.data import KittiDepth

    cal = KittiDepth(kitti_root, split="train", drives=["2011_09_30_drive_9018_sync", "2011_09_30_drive_9020_sync"])
    test = KittiDepth(kitti_root, split="train", drives=["2011_10_03_drive_9034_sync"])[:2]
    wrapper = ConformalIntervalInpainter(ScanlineInpainter(), spread_method="nearest").fit(cal)
    assert wrapper.calibration_["drives"] == ["2011_09_30_drive_9018_sync", "2011_09_30_drive_9020_sync"]
    assert wrapper.calibration_["n_frames"] == 12 and wrapper.calibration_["n_pixels"] > 100_000
    rows = evaluate(wrapper, test, intervals=0.9, progress=False).rows
    assert all(0.5 < r["hole_coverage"] <= 1 and r["rmse_keep_80"] < r["hole_rmse"] for r in rows)


def test_out_of_fold_calibration_of_one_fold_equals_fit_on_its_drives():
    frames = iid_frames(6, seed=2)
    fold = FoldTen(seen=["x0"])
    direct = ConformalIntervalInpainter(FoldTen(seen=[]), signals=("border", "depth")).fit(frames, groups=drives(6))
    full = FoldTen(seen=["d0", "d1", "d2", "x0"])  # saw every drive: only out-of-fold calibration can serve it
    cross = ConformalIntervalInpainter(full, signals=("border", "depth")).fit_out_of_fold(
        [(fold, ArrayDataset(frames, groups=drives(6)))])
    # Equal up to BLAS rounding: least squares on a copy at another address may differ in the last bits.
    np.testing.assert_allclose(cross.coef_, direct.coef_, rtol=1e-8)
    np.testing.assert_allclose(cross.residual_quantiles_, direct.residual_quantiles_, rtol=1e-8)
    assert cross.quantile_ == pytest.approx(direct.quantile_, rel=1e-8)
    assert cross.calibration_["drives"] == ["d0", "d1", "d2"]
    assert cross.calibration_["out_of_fold"] == [
        {"drives": ["d0", "d1", "d2"], "n_frames": 6, "n_pixels": direct.n_calibration_pixels_,
         "training_drives": ["x0"]}]


def test_out_of_fold_calibration_pools_the_folds(tmp_path):
    a, b = iid_frames(4, seed=3), iid_frames(4, seed=4)
    folds = [(FoldTen(seen=["b0", "b1"]), ArrayDataset(a, groups=drives(4, "a"))),
             (FoldTen(seen=["a0", "a1"]), ArrayDataset(b, groups=drives(4, "b")))]
    wrapper = ConformalIntervalInpainter(FoldTen(seen=["a0", "a1", "b0", "b1"]), signals=()).fit_out_of_fold(folds)
    cal = wrapper.calibration_
    assert cal["drives"] == ["a0", "a1", "b0", "b1"] and cal["n_frames"] == 8
    assert cal["n_pixels"] == sum(f["n_pixels"] for f in cal["out_of_fold"]) == wrapper.n_calibration_pixels_
    loaded = ConformalIntervalInpainter.load(wrapper.save(tmp_path / "cal.json"), estimator=FoldTen(seen=[]))
    assert loaded.calibration_["out_of_fold"] == cal["out_of_fold"] and loaded.quantile_ == wrapper.quantile_


@pytest.mark.parametrize("folds, match", [
    ([], "non-empty sequence"),
    ([(FoldTen(seen=[]),)], r"folds\[0\] must be a \(fold model, dataset\) pair"),
    ([(FillTen(), None)], "fold model is a FillTen, the estimator a FoldTen"),
    ([(FoldTen(seen=["d1"]), "frames")], r"folds\[0\]: the fold model was trained on calibration drives \['d1'\]"),
    ([(FoldTen(seen=[]), "frames"), (FoldTen(seen=[]), "frames")], r"drives \['d0', 'd1'\] are in folds\[0\] too"),
])
def test_out_of_fold_calibration_refuses_bad_folds(folds, match):
    frames = ArrayDataset(iid_frames(4, seed=0), groups=drives(4))
    folds = [tuple(frames if v == "frames" else v for v in f) for f in folds]
    with pytest.raises(InvalidInputError, match=match):
        ConformalIntervalInpainter(FoldTen(seen=["d0", "d1"]), signals=()).fit_out_of_fold(folds)


def test_a_fill_that_saw_no_drive_pools_densities_each_drive_once_per_input_kind():
    """The same drives thinned to 16 and to 8 rings are two parts (a drive calibrates once per
    input kind), recorded by kind; the same kind twice is refused."""
    from inpaintenv.data import SyntheticStreets

    def thinned(kind):
        return SyntheticStreets(n=2, frame_shape=(64, 192), seed=5, input=kind)

    fill = FoldTen(seen=[])
    wrapper = ConformalIntervalInpainter(fill, signals=(), protocol="densify-v1").fit_out_of_fold(
        [(fill, thinned("scan-rings16-v1")), (fill, thinned("scan-rings8-v1"))])
    cal = wrapper.calibration_
    assert cal["input_kind"] == "scan-rings16-v1+scan-rings8-v1" and cal["n_frames"] == 4
    assert [f["input_kind"] for f in cal["out_of_fold"]] == ["scan-rings16-v1", "scan-rings8-v1"]
    assert cal["drives"] == sorted({str(g) for g in thinned("scan-rings8-v1").groups})
    with pytest.raises(InvalidInputError, match="are in folds\\[0\\] too \\(input 'scan-rings8-v1'\\)"):
        ConformalIntervalInpainter(fill, signals=(), protocol="densify-v1").fit_out_of_fold(
            [(fill, thinned("scan-rings8-v1")), (fill, thinned("scan-rings8-v1"))])


class CountingTen(FillTen):
    """FillTen counting its predict calls."""

    calls = 0

    def predict(self, X):
        CountingTen.calls += 1
        return super().predict(X)


def test_given_prediction_gives_the_same_interval_without_predicting_again(street_wrapper, street_input):
    pred = street_wrapper.predict(street_input)
    given = street_wrapper.predict_interval(street_input, prediction=pred)
    for a, b in zip(given, street_wrapper.predict_interval(street_input)):
        np.testing.assert_array_equal(a, b)
    with pytest.raises(InvalidInputError, match="prediction has shape"):
        street_wrapper.predict_interval(street_input, prediction=pred[:1])


def test_evaluate_runs_the_base_once_per_batch_for_an_interval():
    wrapper = ConformalIntervalInpainter(CountingTen(), signals=("border",)).fit(iid_frames(4, seed=0), groups=drives(4))
    CountingTen.calls = 0
    result = evaluate(wrapper, iid_frames(3, seed=1), intervals=0.9, progress=False, batch_size=3, warmup=False)
    assert len(result.rows) == 3 and "hole_coverage" in result.rows[0]
    assert CountingTen.calls == 1


def test_an_exact_base_still_gets_a_non_empty_interval():
    wrapper = ConformalIntervalInpainter(FillTen(), signals=()).fit(np.full((4, H, W), 10.0, np.float32),
                                                                      groups=drives(4))
    x = np.full((H, W), 10.0, np.float32)
    x[10:30, 10:40] = np.nan
    low, high = wrapper.predict_interval(x)
    assert wrapper.quantile_ == 1e-6 and ((high - low)[np.isnan(x)] > 0).all()


def test_calibrating_on_scans_calibrates_each_protocols_task():
    """On single scans each protocol calibrates on its task's pixels, as evaluate scores them:
    densify-v1 every pixel the scan did not measure, rect-v1 the hole cut out of the scan; the
    pooled "densify-v1+rect-v1" both, each (protocol, frame) a frame of its own."""
    from estimators.classical import HarmonicInpainter
    from inpaintenv.data import SyntheticStreets, method_input
    from inpaintenv.exceptions import UnknownNameError
    from inpaintenv.masks import get_protocol

    frames = SyntheticStreets(n=3, seed=2, frame_shape=(48, 128), input="scan")
    scans, gt = frames.load_pairs(range(3))
    hole = get_protocol("rect-v1").masks((48, 128), 0, range(3))
    want = {"densify-v1": int(((gt > 0) & (scans == 0)).sum()),
            "rect-v1": int(((gt > 0) & hole & np.isnan(method_input(scans, hole, "scan"))).sum())}
    want["densify-v1+rect-v1"] = want["densify-v1"] + want["rect-v1"]
    for protocol, n in want.items():
        wrapped = ConformalIntervalInpainter(HarmonicInpainter(), spread_method="nearest",
                                             protocol=protocol).fit(frames, groups=["a", "a", "b"])
        assert wrapped.calibration_["n_pixels"] == n, protocol
    assert 0 < want["rect-v1"] < want["densify-v1"]
    with pytest.raises(UnknownNameError, match="nope"):
        ConformalIntervalInpainter(HarmonicInpainter(), protocol="densify-v1+nope").fit(frames, groups=["a", "a", "b"])

def test_the_far_signal_covers_far_and_near_pixels_alike(tmp_path):
    """"far" is 1 beyond FAR_DISTANCE px of a measurement, else 0; its coefficient is set so that
    the far and the near calibration pixels are each covered at the coverage (frame-weighted),
    and a wrapper calibrated with it saves and loads with it."""
    from estimators.classical import HarmonicInpainter
    from estimators.intervals._calibration import FAR_DISTANCE, features, residual_quantiles, scored_residuals
    from estimators.classical import NearestInpainter
    from inpaintenv.data import SyntheticStreets
    from inpaintenv.metrics import border_distance

    hole = np.zeros((80, 80), bool)
    hole[5:75, 5:75] = True
    F = features(("border", "far"), np.full(hole.shape, 10.0), hole, None)
    np.testing.assert_array_equal(F[:, 2], border_distance(hole)[hole] > FAR_DISTANCE)
    frames = SyntheticStreets(n=4, seed=2, frame_shape=(64, 192), input="scan")
    signals = ("border", "depth", "spread", "far")
    wrapped = ConformalIntervalInpainter(HarmonicInpainter(), spread_method="nearest", protocol="densify-v1+rect-v1",
                                         signals=signals).fit(frames, groups=["a", "a", "b", "b"])
    F, r, frame = scored_residuals(HarmonicInpainter(), frames, signals, NearestInpainter(), "densify-v1+rect-v1", 0)
    normed = r / np.exp(F @ wrapped.coef_)
    far = F[:, 4] > 0
    assert far.any() and not far.all()
    q_far, q_near = (residual_quantiles(normed[m], frame[m], "frame", 0.9)[1] for m in (far, ~far))
    assert q_far == pytest.approx(q_near, rel=1e-6)
    back = ConformalIntervalInpainter.load(wrapped.save(tmp_path / "cal.json", base="harmonic"))
    x = frames.load_pairs([0])[0]
    x = np.where(x > 0, x, np.nan)
    np.testing.assert_array_equal(back.predict_interval(x)[1], wrapped.predict_interval(x)[1])
