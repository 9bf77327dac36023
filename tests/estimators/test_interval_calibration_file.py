"""Interval calibration files from outside.

A tampered calibration is refused in one line naming the file and the field, never read
into zero-width intervals; a FIFO or 200 kB of nested JSON is refused at once; ``save``
never writes through a link planted where it writes; a NaN or complex prediction gives
one error, not NaN bounds.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

from estimators.classical import ScanlineInpainter
from estimators.base import iter_scoring_batches
from estimators.intervals import ConformalIntervalInpainter
from estimators.intervals._calibration_file import N_LEVELS
from inpaintenv.exceptions import InvalidInputError, InvalidTypeError

from fifo_checks import returns_within
from streets import streets

H, W = 64, 96


@pytest.fixture(scope="module")
def wrapper() -> ConformalIntervalInpainter:
    frames = streets(6, h=H, w=W, seed=1)
    return ConformalIntervalInpainter(ScanlineInpainter(), spread_method="nearest").fit(frames, groups=list("aabbcc"))


@pytest.fixture(scope="module")
def x() -> np.ndarray:
    batch, _, _ = next(iter_scoring_batches(streets(2, h=H, w=W, seed=7), seed=3))
    return batch


def _load(path: Path) -> ConformalIntervalInpainter:
    return ConformalIntervalInpainter.load(path, estimator=ScanlineInpainter())


def _tampered(wrapper, tmp_path: Path, edit) -> Path:
    doc = wrapper.to_dict("scanline")
    edit(doc)
    path = tmp_path / "tampered.json"
    path.write_text(json.dumps(doc))
    return path


def _set(*keys_and_value):
    *keys, value = keys_and_value

    def edit(doc):
        target = doc
        for key in keys[:-1]:
            target = target[key]
        target[keys[-1]] = value(target[keys[-1]]) if callable(value) else value
    return edit


TAMPERINGS = {
    "negative quantile": (_set("quantile", -5), "quantile"),
    "zero quantile": (_set("quantile", 0), "quantile"),
    "quantile far below the stored ones": (_set("quantile", 1e-9), "quantile"),
    "huge negative coef": (_set("coef", lambda c: [-1e6] + c[1:]), "coef"),
    "coef of the wrong length": (_set("coef", lambda c: c[:-1]), "coef"),
    "negative residual quantiles": (_set("residual_quantiles", lambda r: [-v for v in r]), "residual_quantiles"),
    "decreasing residual quantiles": (_set("residual_quantiles", lambda r: r[::-1]), "residual_quantiles"),
    "too few residual quantiles": (_set("residual_quantiles", lambda r: r[:10]), "residual_quantiles"),
    "n_pixels a word": (_set("n_pixels", "many"), "n_pixels"),
    "n_pixels zero": (_set("n_pixels", 0), "n_pixels"),
    "n_pixels a bool": (_set("n_pixels", True), "n_pixels"),
    "n_pixels too few for the coverage": (lambda d: (_set("n_pixels", 3)(d), _set("calibration", "n_pixels", 3)(d)),
                                          "n_pixels"),
    "n_frames zero": (_set("calibration", "n_frames", 0), "calibration.n_frames"),
    "coverage above 1": (_set("params", "coverage", 1.5), "params.coverage"),
    "coverage a string": (_set("params", "coverage", "0.9"), "params.coverage"),
    "copies disagree on coverage": (_set("calibration", "coverage", 0.5), "calibration.coverage"),
    "copies disagree on n_pixels": (_set("calibration", "n_pixels", lambda n: n + 1), "calibration.n_pixels"),
    "unknown signal": (_set("params", "signals", ["border", "colour"]), "params.signals"),
    "negative seed": (_set("params", "seed", -1), "params.seed"),
    "unknown weighting": (_set("params", "weighting", "drive"), "params.weighting"),
    "calibration a list": (_set("calibration", []), "calibration"),
    # Each number within its bound, together impossible: what the scale implies.
    "intercept -20 (a scale far below its residuals)": (_set("coef", lambda c: [-20.0] + c[1:]), "coef"),
    "intercept +20 (a scale far above any residual)": (_set("coef", lambda c: [20.0] + c[1:]), "coef"),
    "quantiles x1000 and the scale /1000 together": (
        lambda d: (_set("residual_quantiles", lambda r: [v * 1000 for v in r])(d), _set("quantile", lambda q: q * 1000)(d),
                   _set("coef", lambda c: [c[0] - np.log(1000.0)] + c[1:])(d)), "coef"),
}


@pytest.mark.parametrize("name", sorted(TAMPERINGS))
def test_every_field_is_checked_for_what_it_can_mean(wrapper, tmp_path, name):
    edit, field = TAMPERINGS[name]
    path = _tampered(wrapper, tmp_path, edit)
    with pytest.raises(InvalidInputError) as info:
        _load(path)
    message = str(info.value)
    assert "\n" not in message and str(path) in message and repr(field) in message


def test_nan_and_infinity_are_refused_naming_the_file(wrapper, tmp_path):
    path = tmp_path / "nan.json"
    text = json.dumps(wrapper.to_dict("scanline")).replace(f'"quantile": {wrapper.quantile_!r}', '"quantile": NaN')
    assert "NaN" in text
    path.write_text(text)
    with pytest.raises(InvalidInputError, match="nan.json.*NaN"):
        _load(path)


def test_out_of_fold_counts_must_add_up(wrapper, tmp_path):
    doc = wrapper.to_dict("scanline")
    n, frames = doc["n_pixels"], doc["calibration"]["n_frames"]
    doc["calibration"]["out_of_fold"] = [{"drives": ["a"], "n_frames": frames, "n_pixels": n - 1,
                                          "training_drives": []}]
    (tmp_path / "oof.json").write_text(json.dumps(doc))
    with pytest.raises(InvalidInputError, match="out_of_fold"):
        _load(tmp_path / "oof.json")
    doc["calibration"]["out_of_fold"][0]["n_pixels"] = n
    (tmp_path / "oof.json").write_text(json.dumps(doc))
    assert _load(tmp_path / "oof.json").calibration_["out_of_fold"][0]["n_pixels"] == n


def test_the_shipped_calibrations_imply_a_possible_scale():
    """Every shipped file passes the joint check, and its intercept set to -20 (each number
    within its bound; intervals a few millimetres wide) does not."""
    from estimators.intervals import shipped_intervals
    from inpaintenv.values.interval_calibration import check_calibration

    folder = Path(__file__).resolve().parents[2] / "estimators" / "pretrained" / "intervals"
    for name in shipped_intervals():
        doc = json.loads((folder / f"{name}.json").read_text())
        check_calibration(doc, name)
        doc["coef"][0] = -20.0
        with pytest.raises(InvalidInputError, match=f"{name}: 'coef' must be a scale that reaches"):
            check_calibration(doc, name)


def test_untouched_files_still_load(wrapper, tmp_path, x):
    back = _load(wrapper.save(tmp_path / "cal.json", base="scanline"))
    for a, b in zip(back.predict_interval(x), wrapper.predict_interval(x)):
        np.testing.assert_array_equal(a, b)
    assert back.residual_quantiles_.shape == (N_LEVELS,)


def test_deeply_nested_json_is_one_line(tmp_path):
    path = tmp_path / "nested.json"
    path.write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(InvalidInputError) as info:
        _load(path)
    assert "nested" in str(info.value) and "\n" not in str(info.value)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_a_fifo_is_refused_at_once(tmp_path):
    fifo = tmp_path / "cal.json"
    os.mkfifo(fifo)
    error = returns_within(10, lambda: _load(fifo), fifo)
    assert isinstance(error, InvalidInputError) and "FIFO" in str(error), error


def test_save_never_writes_through_a_planted_link(wrapper, tmp_path):
    victim = tmp_path / "victim.txt"
    victim.write_text("keep me")
    out = tmp_path / "out"
    out.mkdir()
    target = out / "cal.json"
    # The former temporary name (predictable from the pid) and the target itself, both links.
    (out / f".cal.json.tmp-{os.getpid()}").symlink_to(victim)
    wrapper.save(target, base="scanline")
    assert victim.read_text() == "keep me"
    target.unlink()
    target.symlink_to(victim)
    wrapper.save(target, base="scanline")
    assert victim.read_text() == "keep me" and not target.is_symlink()
    assert _load(target).quantile_ == wrapper.quantile_


def test_nan_prediction_is_refused_naming_the_method_and_frame(wrapper, x):
    pred = wrapper.predict(x)
    pred[1, 5, 5] = np.nan
    with pytest.raises(InvalidInputError, match=r"predict_interval.*NaN or inf depth in frame 1"):
        wrapper.predict_interval(x, prediction=pred)


class _NaNBase(ScanlineInpainter):
    def predict(self, X):
        out = super().predict(X)
        out[..., 0, 0] = np.nan
        return out


def test_a_base_predicting_nan_is_refused(wrapper, x):
    broken = ConformalIntervalInpainter(_NaNBase(), spread_method="nearest")
    for attr in ("coef_", "residual_quantiles_", "quantile_", "n_calibration_pixels_", "calibration_"):
        setattr(broken, attr, getattr(wrapper, attr))
    with pytest.raises(InvalidInputError, match=r"_NaNBase has NaN or inf depth in frame 0"):
        broken.predict_interval(x)
    with pytest.raises(InvalidInputError, match="return_std"):
        broken.predict(x, return_std=True)


def test_complex_prediction_is_refused(wrapper, x):
    with pytest.raises(InvalidTypeError, match="complex"):
        wrapper.predict_interval(x, prediction=wrapper.predict(x).astype(np.complex64))
