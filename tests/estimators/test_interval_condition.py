"""Mondrian (per-bin) conformal quantiles: each bin's quantile, the wrapper's widths, the file's ``condition``."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from estimators.base import iter_scoring_batches
from estimators.intervals import ConformalIntervalInpainter, cell_quantiles, fit_condition
from estimators.intervals._calibration import features, scale_from
from estimators.intervals._mondrian import MIN_CELL_FRAMES, MIN_CELL_PIXELS
from inpaintenv.exceptions import InvalidInputError, InvalidTypeError
from inpaintenv.metrics import border_distance
from inpaintenv.methods.registry import make_method

from stand_ins import FillTen

H, W = 64, 96
EDGES = (2.0, 4.0, 8.0, 16.0, 64.0)


@pytest.fixture(scope="module")
def pixels():
    """Design matrix (intercept, log(1 + distance), log depth), normalised residuals wider far from a
    measurement, and 40 frames of unequal sizes."""
    rng = np.random.default_rng(5)
    n = 30_000
    distance = rng.gamma(2.0, 6.0, n)
    F = np.column_stack([np.ones(n), np.log1p(distance), np.log(rng.uniform(1.0, 80.0, n))])
    normed = rng.exponential(1.0, n) * (1.0 + (distance > 8.0))
    frame = (40 * rng.random(n) ** 3).astype(np.int64)  # frames of very different sizes
    return F, normed, frame, distance


def _numpy_quantile(v: np.ndarray, weights: np.ndarray, weighting: str, c: float) -> float:
    """The split-conformal order statistic (pixel), or the smallest value whose weighted share reaches c."""
    if weighting == "pixel":
        return float(np.sort(v)[math.ceil((v.size + 1) * c) - 1])
    order = np.argsort(v)
    cdf = np.cumsum(weights[order]) / weights.sum()
    return float(v[order][np.argmax(cdf >= c - 1e-12)])


@pytest.mark.parametrize("weighting", ["pixel", "frame"])
def test_each_bin_quantile_is_numpys_on_the_bins_pixels(pixels, weighting):
    F, normed, frame, distance = pixels
    doc = fit_condition("distance", EDGES, ("border", "depth"), F, normed, frame, weighting, 0.9)
    bins = np.digitize(distance, EDGES, right=True)  # bin b: edges[b-1] < d <= edges[b]
    weights = 1.0 / np.bincount(frame)[frame]  # 1 / (the frame's pixels, every bin)
    own = 0
    for b, cell in enumerate(doc["bins"]):
        inside = bins == b
        assert cell["n_pixels"] == int(inside.sum()) and cell["n_frames"] == np.unique(frame[inside]).size
        if inside.sum() < MIN_CELL_PIXELS or cell["n_frames"] < MIN_CELL_FRAMES:
            assert cell["quantile"] is None and cell["residual_quantiles"] is None  # the pooled one
            continue
        own += 1
        v = normed[inside]
        assert cell["quantile"] == pytest.approx(_numpy_quantile(v, weights[inside], weighting, 0.9), rel=1e-12)
        assert cell["residual_quantiles"][0] == v.min() and cell["residual_quantiles"][-1] == v.max()
    assert own == 4 and doc["bins"][0]["quantile"] is None and doc["bins"][-1]["quantile"] is None
    # Far bins err twice as much: their quantile is about twice the near ones'.
    assert doc["bins"][4]["quantile"] > 1.7 * doc["bins"][2]["quantile"]
    q = cell_quantiles(doc, 7.0, 0.9, True, weighting)
    assert q[0] == q[-1] == 7.0 and list(q[1:-1]) == [doc["bins"][b]["quantile"] for b in range(1, 5)]
    # Another coverage: read from the 201 stored levels, at or above the exact one and within a level of it.
    half = cell_quantiles(doc, 7.0, 0.5, False, weighting)
    for b in range(1, 5):
        v = normed[bins == b]
        w = weights[bins == b]
        assert _numpy_quantile(v, w, weighting, 0.5) <= half[b] <= _numpy_quantile(v, w, weighting, 0.51)


@pytest.fixture(scope="module")
def noisy():
    rng = np.random.default_rng(2)
    return np.clip(10.0 + 2.0 * rng.standard_normal((16, H, W)), 0.1, None).astype(np.float32)


@pytest.fixture(scope="module")
def pair(noisy):
    groups = [f"d{k // 2}" for k in range(len(noisy))]
    kw = {"signals": ("border",), "weighting": "pixel"}
    plain = ConformalIntervalInpainter(FillTen(), **kw).fit(noisy, groups=groups)
    cond = ConformalIntervalInpainter(FillTen(), condition="distance", condition_edges=(2.0, 5.0, 10.0),
                                      **kw).fit(noisy, groups=groups)
    return plain, cond


def test_each_bin_of_the_calibration_frames_is_covered_and_the_scale_is_unchanged(noisy, pair):
    plain, cond = pair
    np.testing.assert_allclose(cond.coef_, plain.coef_, rtol=1e-6)  # the same least squares (BLAS rounding aside)
    # The masks fit used: frame i gets mask i of seed 0.
    x, gt, hole = (np.concatenate(parts) for parts in zip(*iter_scoring_batches(noisy)))
    low, high = cond.predict_interval(x)
    plow, phigh = plain.predict_interval(x)
    bins = np.digitize(border_distance(hole), (2.0, 5.0, 10.0), right=True)
    q = cell_quantiles(cond.condition_, cond.quantile_, 0.9, True, "pixel")
    own = [b for b, cell in enumerate(cond.condition_["bins"]) if cell["quantile"] is not None]
    assert len(own) >= 2
    for b in range(len(q)):
        at = hole & (gt > 0) & (bins == b)
        if not at.any():
            continue
        # The width is the unconditioned one rescaled by the bin's q over the pooled q.
        np.testing.assert_allclose((high - low)[at],
                                   (phigh - plow)[at] * q[b] / plain.quantile_, rtol=1e-5)
        if b in own:
            assert np.mean((gt[at] >= low[at]) & (gt[at] <= high[at])) >= 0.9 - 1e-3


def test_a_conditioned_file_round_trips_and_an_old_one_has_no_condition(pair, noisy, tmp_path):
    plain, cond = pair
    x, _, _ = next(iter_scoring_batches(noisy[:2], seed=3))
    back = ConformalIntervalInpainter.load(cond.save(tmp_path / "c.json", base="x"), estimator=FillTen())
    for a, b in zip(back.predict_interval(x, 0.8), cond.predict_interval(x, 0.8)):
        np.testing.assert_allclose(a, b, rtol=1e-6)  # F @ coef's BLAS rounding may differ by an ulp
    assert back.condition == "distance" and back.condition_ == cond.condition_
    assert "condition" not in plain.to_dict("x")


SHIPPED = Path(__file__).resolve().parents[2] / "estimators" / "pretrained" / "intervals"


@pytest.mark.parametrize("name", ["routes/sparse-kitti-sparse-v1", "harmonic-ipbasic", "scanline"])
def test_a_shipped_file_without_the_field_loads_and_predicts_pooled(name):
    doc = json.loads((SHIPPED / f"{name}.json").read_text())
    if "condition" in doc:
        pytest.skip("this file ships a condition")
    wrapper = ConformalIntervalInpainter.load(SHIPPED / f"{name}.json", estimator=make_method(doc["base"]))
    assert wrapper.condition is None and wrapper.condition_ is None and wrapper.to_dict(doc["base"]) == doc
    rng = np.random.default_rng(0)
    x = np.where(rng.random((1, 48, 80)) < 0.3, 5.0 + 20.0 * rng.random((1, 48, 80)), np.nan).astype(np.float32)
    low, high = wrapper.predict_interval(x)
    pred = np.asarray(wrapper.predict(x), np.float32)
    hole = np.isnan(x)
    other = None
    if wrapper.calibration_["spread_method"]:
        other = np.asarray(make_method(wrapper.calibration_["spread_method"]).predict(x), np.float64)[0]
    half = wrapper.quantile_ * scale_from(wrapper.coef_, features(wrapper.calibration_["signals"], pred[0], hole[0],
                                                                 other))
    np.testing.assert_allclose(high[hole], pred[hole] + half, rtol=1e-6)


def _edit(cond, **changes):
    doc = cond.to_dict("x")
    for path, value in changes.items():
        target = doc["condition"]
        *keys, last = path.split("__")
        for key in keys:
            target = target[int(key)] if isinstance(target, list) else target[key]
        target[int(last) if isinstance(target, list) else last] = value(target[int(last) if isinstance(
            target, list) else last]) if callable(value) else value
    return doc


MALFORMED = {
    "bins a number": ({"bins": 3}, "condition.bins"),
    "one bin too few": ({"bins": lambda b: b[:-1]}, "condition.bins"),
    "a bin a list": ({"bins__0": []}, "condition.bins"),
    "edges decreasing": ({"edges": lambda e: e[::-1]}, "condition.edges"),
    "edges empty": ({"edges": []}, "condition.edges"),
    "edges a word": ({"edges": "far"}, "condition.edges"),
    "unknown variable": ({"variable": "colour"}, "condition.variable"),
    "another version": ({"version": 2}, "condition.version"),
    "counts not adding up": ({"bins__0__n_pixels": lambda n: n + 1}, "condition.bins[*].n_pixels"),
    "negative count": ({"bins__0__n_pixels": -1}, "condition.bins[0].n_pixels"),
    "a quantile 1000x the pooled one": ({"bins__OWN__quantile": lambda q: q * 1000,
                                         "bins__OWN__residual_quantiles": lambda r: [v * 1000 for v in r]},
                                        "condition.bins[OWN].quantile"),
    "a quantile off its stored ones": ({"bins__OWN__quantile": lambda q: q * 3}, "condition.bins[OWN].quantile"),
    "decreasing stored quantiles": ({"bins__OWN__residual_quantiles": lambda r: r[::-1]},
                                    "condition.bins[OWN].residual_quantiles"),
    "a quantile for a bin under the minimum": ({"min_pixels": 10 ** 9}, "condition.bins[OWN].quantile"),
    "a pooled bin with half its fields": ({"bins__OWN__quantile": None}, "condition.bins[OWN].quantile"),
    "a field missing": ({"min_frames": None}, "condition.min_frames"),
}


@pytest.mark.parametrize("name", sorted(MALFORMED))
def test_a_malformed_condition_is_one_error_naming_the_field(pair, tmp_path, name):
    _, cond = pair
    own = next(b for b, cell in enumerate(cond.condition_["bins"]) if cell["quantile"] is not None)
    changes, field = MALFORMED[name]
    doc = _edit(cond, **{k.replace("OWN", str(own)): v for k, v in changes.items()})
    if name == "a field missing":
        del doc["condition"]["min_frames"]
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(InvalidInputError) as info:
        ConformalIntervalInpainter.load(path, estimator=FillTen())
    message = str(info.value)
    assert str(path) in message and repr(field.replace("OWN", str(own))) in message and "\n" not in message


@pytest.mark.parametrize("params, match", [
    ({"condition": "colour"}, "^condition must be"),
    ({"condition": "distance", "condition_edges": (4.0, 2.0)}, "condition_edges must be increasing"),
    ({"condition_edges": (2.0,)}, "condition_edges need a condition"),
])
def test_bad_condition_parameters_are_one_error(noisy, params, match):
    with pytest.raises((InvalidInputError, InvalidTypeError), match=match):
        ConformalIntervalInpainter(FillTen(), signals=("border",), **params).fit(noisy[:2], groups=["a", "b"])


@pytest.mark.parametrize("condition", ["depth", "density", "frame_density"])
def test_a_condition_the_scale_does_not_use_leaves_the_scale_as_it_is(noisy, pair, condition):
    """The variable's signal is computed beside the scale's: the scale and pooled quantile stay the unconditioned ones."""
    plain, _ = pair
    groups = [f"d{k // 2}" for k in range(len(noisy))]
    cond = ConformalIntervalInpainter(FillTen(), signals=("border",), weighting="pixel", condition=condition,
                                      condition_edges=(5.0, 20.0) if condition == "depth" else (0.2, 0.5)).fit(
        noisy, groups=groups)
    assert cond.coef_.shape == (2,) and cond.quantile_ == pytest.approx(plain.quantile_, rel=1e-6)
    assert sum(cell["n_pixels"] for cell in cond.condition_["bins"]) == cond.n_calibration_pixels_
    x, _, _ = next(iter_scoring_batches(noisy[:2], seed=3))
    low, high = cond.predict_interval(x)
    assert np.isfinite(low).all() and (high >= low).all()


def test_the_density_signal_is_the_measured_share_around_each_pixel():
    from inpaintenv.values.interval_calibration import DENSITY_WINDOW

    hole = np.ones((80, 120), bool)
    hole[40, 60] = False  # one measurement
    F = features(("density",), np.full(hole.shape, 5.0, np.float32), hole, None)
    share = np.zeros(hole.shape)
    r = DENSITY_WINDOW // 2
    share[40 - r:40 + r + 1, 60 - r:60 + r + 1] = 1.0 / DENSITY_WINDOW ** 2
    np.testing.assert_allclose(F[:, 1], share[hole], atol=1e-7)


def test_the_frame_density_signal_is_the_measured_share_of_the_measured_rows():
    hole = np.ones((80, 120), bool)
    hole[10, :30] = False  # 30 measured pixels in row 10, 6 in row 50, none elsewhere
    hole[50, ::20] = False
    F = features(("frame_density",), np.full(hole.shape, 5.0, np.float32), hole, None)
    np.testing.assert_array_equal(F[:, 1], np.full(int(hole.sum()), 36 / (2 * 120)))
    assert features(("frame_density",), np.ones((4, 5), np.float32), np.ones((4, 5), bool), None)[:, 1].max() == 0
