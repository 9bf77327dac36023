"""MeanEnsembleInpainter: the mean of its members, shared features, parameters, persistence, errors."""

from __future__ import annotations

import json

import numpy as np
import pytest
from sklearn.base import clone
from streets import streets as _streets

from estimators.classical import HarmonicInpainter
from estimators.learned import MeanEnsembleInpainter
from estimators.learned._checkpoint import (
    CheckpointError,
    read_checkpoint,
    write_checkpoint,
)
from estimators.learned import BlendInpainter
from estimators.learned import ContextBlendInpainter
from estimators.learned import load
from inpaintenv.data import ArrayDataset

CONTEXT = dict(n_context=2, context_widths=(4, 8), width=8, layers=1, epochs=1, masks_per_frame=1, keep=(1.0,),
               pixels_per_frame=200, batch_frames=3, batch_pixels=64, num_threads=1)
BLEND = dict(width=8, layers=1, epochs=1, masks_per_frame=1, pixels_per_frame=200, batch_pixels=64, num_threads=1)


def _members(**blend):
    return [("context", ContextBlendInpainter(**CONTEXT)), ("blend", BlendInpainter(**{**BLEND, **blend}))]


@pytest.fixture(scope="module")
def data() -> ArrayDataset:
    return ArrayDataset(_streets(), groups=list("aaaabc"))


@pytest.fixture(scope="module")
def fitted(data) -> MeanEnsembleInpainter:
    return MeanEnsembleInpainter(_members(tta=False)).fit(data)


def _corrupt(gt: np.ndarray) -> np.ndarray:
    x = gt.copy()
    x[10:25, 30:70] = np.nan
    return x


def test_predicts_the_mean_of_its_members_from_shared_features(fitted):
    assert fitted.shares_features_
    x = _corrupt(_streets(1, seed=5)[0])
    pred = fitted.predict(x)
    members = [m.predict(x) for m in fitted.estimators_]
    hole = np.isnan(x)
    np.testing.assert_allclose(pred[hole], np.mean(members, axis=0)[hole], rtol=1e-6)
    np.testing.assert_array_equal(pred[x > 0], x[x > 0])  # measurements kept
    assert pred.dtype == np.float32 and np.isfinite(pred).all() and not np.allclose(members[0][hole], members[1][hole])
    batch = fitted.predict(np.stack([x, 2 * x]))  # a batch, and scale-free like its members
    np.testing.assert_allclose(batch[1], 2 * batch[0], rtol=2e-4)


def test_each_member_is_fitted_as_on_its_own(fitted, data):
    alone = BlendInpainter(**BLEND, tta=False).fit(data)
    member = fitted.named_estimators_["blend"]
    for a, b in zip(alone.model_.state_dict().values(), member.model_.state_dict().values()):
        assert np.array_equal(a.numpy(), b.numpy())
    assert fitted.training_drives_ is None or fitted.training_drives_ == member.training_drives_
    assert set(fitted.history_["epoch_loss_by_member"]) == {"context", "blend"}
    assert len(fitted.member_fit_seconds_) == 2 and fitted.fit_seconds_ >= sum(fitted.member_fit_seconds_) * 0.99


def test_shared_parameters_reach_every_member_that_has_them(data):
    est = MeanEnsembleInpainter(_members(), random_state=7, num_threads=1).fit(data[:3])
    assert [m.random_state for m in est.estimators_] == [7, 7] and [m.seed_ for m in est.estimators_] == [7, 7]
    with pytest.raises(ValueError, match="num_threads"):
        MeanEnsembleInpainter(_members(), num_threads=0).fit(data)


def test_members_of_other_families_are_averaged_without_sharing(data):
    est = MeanEnsembleInpainter([("blend", BlendInpainter(**BLEND)), ("harmonic", HarmonicInpainter())]).fit(data)
    assert not est.shares_features_
    x = _corrupt(_streets(1, seed=2)[0])
    expected = np.mean([m.predict(x) for m in est.estimators_], axis=0)
    np.testing.assert_allclose(est.predict(x), np.where(x > 0, x, expected), rtol=1e-6)


def test_nested_parameters_as_in_scikit_learn(fitted):
    params = fitted.get_params()
    assert params["blend__tta"] is False and params["context__n_context"] == 2
    assert isinstance(params["context"], ContextBlendInpainter)
    est = clone(fitted).set_params(blend__lr=1e-3, predict_threads=2)
    assert est.get_params()["blend__lr"] == 1e-3 and est.predict_threads == 2
    loaded = clone(fitted)
    with pytest.raises(ValueError, match=r"invalid parameter 'nope__lr'.*members \['blend', 'context'\]"):
        loaded.set_params(nope__lr=1)
    # a prediction-time change reaches the fitted member too
    fitted_copy = MeanEnsembleInpainter.from_fitted([(n, m) for n, m in fitted.named_estimators_.items()])
    fitted_copy.set_params(blend__tta=True)
    assert fitted_copy.named_estimators_["blend"].tta is True
    fitted_copy.set_params(blend__tta=False)


@pytest.mark.parametrize("members, message", [
    ([("a", BlendInpainter())], "at least two"),
    ([("a", BlendInpainter()), ("a", BlendInpainter())], "unique"),
    ([("a__b", BlendInpainter()), ("c", BlendInpainter())], "letters, digits and single underscores"),
    ([("a", BlendInpainter()), ("c", 3)], "not an inpainter"),
    ([("a", BlendInpainter()), ("verbose", BlendInpainter())], "differ from the ensemble's parameters"),
    ([BlendInpainter(), BlendInpainter()], r"\(name, estimator\) pair"),
])
def test_bad_members_are_named_at_fit(members, message, data):
    est = MeanEnsembleInpainter(members)  # init and set_params never raise (scikit-learn's contract)
    with pytest.raises(ValueError, match=message):
        est.fit(data)


def test_save_load_round_trip_in_one_checkpoint(fitted, tmp_path):
    folder = fitted.save(tmp_path / "ens")
    assert sorted(p.name for p in folder.iterdir()) == ["config.json", "model.safetensors"]
    config, weights, _, _ = read_checkpoint(folder)
    assert [m["name"] for m in config["members"]] == ["context", "blend"]
    assert {k.split(".")[0] for k in weights} == {"context", "blend"}
    loaded = load(folder)
    assert isinstance(loaded, MeanEnsembleInpainter) and loaded.shares_features_
    x = _corrupt(_streets(1, seed=4)[0])
    np.testing.assert_array_equal(loaded.predict(x), fitted.predict(x))
    assert loaded.named_estimators_["blend"].tta is False


def test_corrupt_or_foreign_checkpoints_are_refused(fitted, tmp_path):
    folder = fitted.save(tmp_path / "ens")
    config, weights, _, _ = read_checkpoint(folder)
    stray = write_checkpoint(tmp_path / "stray", {k: v for k, v in config.items() if k != "weights_sha256"},
                             {**weights, "other.w": weights[next(iter(weights))].clone()})
    with pytest.raises(CheckpointError, match="weights of no member"):
        MeanEnsembleInpainter.load(stray)
    alone = fitted.named_estimators_["blend"].save(tmp_path / "blend")
    with pytest.raises(CheckpointError, match="holds a 'BlendInpainter', not a MeanEnsembleInpainter"):
        MeanEnsembleInpainter.load(alone)
    raw = (folder / "model.safetensors").read_bytes()
    (folder / "model.safetensors").write_bytes(raw[:-10])
    with pytest.raises(CheckpointError, match="checksum"):
        load(folder)
    with pytest.raises(ValueError, match="not fitted"):
        MeanEnsembleInpainter(_members()).save(tmp_path / "nothing")


def test_from_fitted_joins_saved_models(fitted, tmp_path):
    a = fitted.named_estimators_["context"].save(tmp_path / "a")
    b = fitted.named_estimators_["blend"].save(tmp_path / "b")
    joined = MeanEnsembleInpainter.from_fitted([("context", load(a)), ("blend", load(b))])
    x = _corrupt(_streets(1, seed=6)[0])
    np.testing.assert_array_equal(joined.predict(x), fitted.predict(x))
    with pytest.raises(ValueError, match=r"members not fitted: \['blend'\]"):
        MeanEnsembleInpainter.from_fitted([("context", load(a)), ("blend", BlendInpainter())])


def test_the_preset_holds_the_two_shipped_recipes():
    from estimators.learned.presets import PRESETS, make_preset

    est = make_preset("ensemble-kitti", random_state=3)
    members = dict(est.estimators)
    for name, preset, changed in (("context", "context-kitti-draws", {}), ("blend", "blend-kitti", {"tta": False})):
        _, params, _ = PRESETS[preset]
        assert {k: members[name].get_params()[k] for k in params} == {**params, **changed}
    assert est.random_state == 3
    again = make_preset("ensemble-kitti")
    assert dict(again.estimators)["blend"] is not members["blend"]  # each call builds its own members


def test_config_is_plain_json(fitted, tmp_path):
    config = json.loads((fitted.save(tmp_path / "e") / "config.json").read_text())
    assert config["class"] == "MeanEnsembleInpainter" and "estimators" not in config["params"]
    assert config["members"][1]["config"]["class"] == "BlendInpainter"


def test_grid_search_over_a_members_parameter_grouped_by_drive(data):
    from sklearn.model_selection import GridSearchCV, GroupKFold

    search = GridSearchCV(MeanEnsembleInpainter(_members(tta=False)), {"blend__residual": [False, True]},
                          cv=GroupKFold(2))
    search.fit(data, groups=data.groups)
    assert np.isfinite(search.cv_results_["mean_test_score"]).all() and set(search.best_params_) == {"blend__residual"}
    assert search.best_estimator_.named_estimators_["blend"].residual == search.best_params_["blend__residual"]


def test_weighted_mean_as_in_voting_regressor(fitted, tmp_path):
    x = _corrupt(_streets(1, seed=5)[0])
    hole = np.isnan(x)
    members = [m.predict(x) for m in fitted.estimators_]
    weighted = MeanEnsembleInpainter.from_fitted(list(fitted.named_estimators_.items()), weights=(3, 1))
    pred = weighted.predict(x)
    np.testing.assert_allclose(pred[hole], (0.75 * members[0] + 0.25 * members[1])[hole], rtol=1e-5)
    # equal weights are the plain mean; one member alone is that member
    np.testing.assert_allclose(weighted.set_params(weights=[1, 1]).predict(x), fitted.predict(x), rtol=1e-6)
    np.testing.assert_allclose(weighted.set_params(weights=[0, 2]).predict(x)[hole], members[1][hole], rtol=1e-6)
    loaded = load(weighted.set_params(weights=(3, 1)).save(tmp_path / "weighted"))
    assert loaded.weights == [3.0, 1.0]
    np.testing.assert_array_equal(loaded.predict(x), pred)


@pytest.mark.parametrize("weights, message", [
    ([1], "one number per member"),
    ([1, 2, 3], "one number per member"),
    ([1, -1], "non-negative"),
    ([0, 0], "not all zero"),
    ([1, float("nan")], "finite"),
    (["a", 1], "numbers"),
])
def test_bad_weights_are_named(weights, message, fitted, data):
    x = _corrupt(_streets(1, seed=5)[0])
    with pytest.raises(ValueError, match=message):
        MeanEnsembleInpainter.from_fitted(list(fitted.named_estimators_.items()), weights=weights).predict(x)
    with pytest.raises(ValueError, match=message):
        MeanEnsembleInpainter(_members(), weights=weights).fit(data)
