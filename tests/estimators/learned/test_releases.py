"""Every shipped release (estimators/pretrained): it loads by name as the class its JSON records,
its JSON is its recipe (preset NAME), it records its training drives, fills full frames of every
KITTI size keeping measurements, saves and loads back to the same predictions, and beats the
classical methods on real frames it never saw (with the KITTI slice)."""

from __future__ import annotations

import importlib.util
import json
import re
from pathlib import Path

import numpy as np
import pytest
from param_values import param_values
from release_checks import (
    FRAME_SHAPES,
    check_beats_every_classical_method,
    check_full_frame,
    classes_in_fresh_processes,
)

from estimators.learned import PriorUNetInpainter, load, load_release
from estimators.learned.presets import PRESET_ALIASES, PRESETS, make_preset
from inpaintenv.data import SyntheticStreets
from inpaintenv.exceptions import CheckpointError
from inpaintenv.masks import get_protocol
from inpaintenv.methods.learned import DEFAULT_RELEASE, RELEASE_DIR, shipped
from inpaintenv.methods.registry import make_method

RELEASES = sorted(shipped())
#: Parameters a release records that belong to the run that made it, not to its recipe.
RUN_PARAMS = ("verbose",)


def _config(name: str) -> dict:
    return json.loads((RELEASE_DIR / f"{name}.json").read_text())


@pytest.fixture(scope="module", params=RELEASES)
def release(request):
    return request.param, load_release(request.param)


def _frame(shape=(64, 192)) -> tuple[np.ndarray, np.ndarray]:
    gt = SyntheticStreets(n=1, seed=3, frame_shape=shape)[0]
    hole = get_protocol("rect-v1").mask(gt.shape, 0, 0)
    return np.where(hole, np.nan, gt).astype(np.float32), hole


def test_the_package_ships_the_default_the_free_form_the_scan_and_the_sparse_release():
    assert RELEASES == ["kitti-ensemble-v1", "kitti-mixed-v1", "kitti-scan-v1", "kitti-sparse-v1"]
    assert DEFAULT_RELEASE == "kitti-ensemble-v1"
    assert type(load_release("kitti-scan-v1")).__name__ == "ScanBlendInpainter"
    assert type(load_release("kitti-sparse-v1")).__name__ == "SparseResidualInpainter"
    assert type(make_method("pretrained").map_method).__name__ == "MeanEnsembleInpainter"
    assert param_values(make_method("blend-pretrained-mixed")) == param_values(load_release("kitti-mixed-v1"))


def test_the_shipped_files_fit_a_small_wheel():
    """The wheel stays under 4 MB: the release files are most of it (2.3 MB with both releases)."""
    size = sum(p.stat().st_size for p in RELEASE_DIR.iterdir())
    assert size < 3_000_000, f"estimators/pretrained holds {size:,} bytes"


def test_one_load_function_and_one_default():
    """``load(path)`` and ``load_release(name)``, each at estimators.learned only; the default release
    and the list of releases defined once, in the torch-free module the registry reads too."""
    import estimators
    import estimators.learned as learned
    from estimators.learned._persistence import PersistenceMixin

    assert not hasattr(learned, "load_checkpoint") and not hasattr(PersistenceMixin, "pretrained")
    assert not hasattr(estimators, "load") and not hasattr(estimators, "load_release")
    assert importlib.util.find_spec("estimators.learned.releases") is None
    root = Path(estimators.__file__).parents[1]
    sources = {p: p.read_text() for pkg in ("estimators", "inpaintenv") for p in (root / pkg).rglob("*.py")}
    defines = lambda pattern: sorted(str(p.relative_to(root)) for p, s in sources.items()  # noqa: E731
                                     if re.search(pattern, s, re.M))
    assert defines(r"^DEFAULT_RELEASE\b.*=") == ["inpaintenv/methods/learned.py"]
    assert defines(r"^def (shipped|shipped_releases)\(") == ["inpaintenv/methods/learned.py"]


def test_an_ensemble_nests_its_members_configs(tmp_path):
    est = load_release()
    config = json.loads((est.save(tmp_path / "ens") / "config.json").read_text())
    members = {m["name"]: m["config"] for m in config["members"]}
    assert list(members) == ["context", "blend"]
    assert {m["class"] for m in members.values()} == {"ContextBlendInpainter", "BlendInpainter"}
    assert all(m["training_drives"] == config["training_drives"] for m in members.values())
    assert not any(k in m for m in members.values() for k in ("format", "weights_sha256"))  # one file's keys


def test_loads_by_name_as_the_class_its_json_records(release):
    name, est = release
    assert type(est).__name__ == _config(name)["class"] == shipped()[name]
    assert param_values(make_method(name)) == param_values(est)
    assert est.is_fitted_


def test_loads_in_a_fresh_process_by_registry_name():
    """A fresh interpreter (as the CLI is) finds each release's class without importing it first."""
    assert classes_in_fresh_processes(RELEASES) == {name: shipped()[name] for name in RELEASES}


def _recipe_params(est) -> dict:
    """Every parameter, an ensemble's members' as ``name__param`` (not the member objects)."""
    members = {name for name, _ in getattr(est, "estimators", [])} | {"estimators"}
    return {k: v for k, v in param_values(est.get_params(deep=True)).items()
            if k not in members and k.rpartition("__")[2] not in RUN_PARAMS}


def test_preset_of_the_release_name_is_its_json(release):
    """`inpaintenv train --preset NAME` builds the very estimator the release's JSON records."""
    name, est = release
    cls, params, _ = PRESETS[name]
    assert cls is type(est)
    assert _recipe_params(make_preset(name)) == _recipe_params(est)


@pytest.mark.parametrize(("alias", "target"), sorted(PRESET_ALIASES.items()))
def test_former_preset_names_are_the_release_named_presets(alias, target):
    assert param_values(make_preset(alias)) == param_values(make_preset(target))
    assert target in PRESETS[alias][2]  # the description names what it trains


def test_release_records_its_training_drives(release):
    name, est = release
    drives = _config(name)["training_drives"]
    assert est.training_drives_ == drives and drives
    assert not any(d.startswith("2011_10_03_drive_91") for d in drives)  # the val drive stays unseen
    for member in _config(name).get("members", []):  # an ensemble's members saw the same frames
        assert member["config"]["training_drives"] == drives


def test_default_records_its_machine():
    env = _config(DEFAULT_RELEASE)["environment"]
    assert {"python", "cpu_count"} <= set(env) and "torch" in json.dumps(env)


def test_saved_and_loaded_back_predicts_the_same(release, tmp_path):
    name, est = release
    x, _ = _frame()
    path = est.save(tmp_path / name)
    config = json.loads((path / "config.json").read_text())
    assert config["class"] == type(est).__name__
    again = load(path)
    assert type(again) is type(est) and param_values(again) == param_values(est)
    np.testing.assert_array_equal(again.predict(x), est.predict(x))


def test_a_class_loads_only_its_own_checkpoints(tmp_path):
    folder = load_release(DEFAULT_RELEASE).save(tmp_path / "ensemble")
    with pytest.raises(CheckpointError, match="MeanEnsembleInpainter.*not a PriorUNetInpainter"):
        PriorUNetInpainter.load(folder)
    assert isinstance(PriorUNetInpainter.load(load_release("kitti-mixed-v1").save(tmp_path / "mixed")),
                      PriorUNetInpainter)


def test_unknown_release_lists_the_shipped_ones():
    with pytest.raises(KeyError, match="kitti-ensemble-v1.*kitti-mixed-v1.*kitti-scan-v1.*kitti-sparse-v1"):
        load_release("kitti-rect-v4")


def test_prediction_time_overrides_but_not_the_architecture():
    est = load_release("kitti-mixed-v1", num_threads=1, tta=False, device="cpu", batch_size=1)
    assert est.tta is False and est.num_threads == 1
    with pytest.raises(ValueError, match=r"^width=64 differs from the 128 this model was trained with"):
        load_release("kitti-mixed-v1", width=64)
    ensemble = load_release(DEFAULT_RELEASE, predict_threads=2, blend__tta=True)
    assert ensemble.predict_threads == 2 and ensemble.named_estimators_["blend"].tta is True
    with pytest.raises(ValueError, match="candidates"):
        load_release(DEFAULT_RELEASE, blend__candidates=("scanline",))


@pytest.mark.parametrize("shape", FRAME_SHAPES)
def test_full_frame_of_every_size_keeps_measurements_and_is_fast(release, shape):
    check_full_frame(release[1], shape)


@pytest.mark.kitti
@pytest.mark.slow
def test_default_beats_every_classical_method_on_the_unseen_val_drive(kitti_root):
    """The shared slice's ``val`` drive (official KITTI maps) was never trained or selected
    on: mean hole RMSE over five mask seeds below that of every method of estimators.classical."""
    from inpaintenv.data import KittiDepth

    check_beats_every_classical_method(load_release(), DEFAULT_RELEASE, KittiDepth(kitti_root, split="val"),
                                       [0, 1, 2, 3, 4])


#: Releases made for a sparser LiDAR's scan (not a map): the input their real-frame check gets.
SPARSE_INPUT = {"kitti-sparse-v1": "scan-rings16-v1"}


@pytest.mark.kitti
@pytest.mark.slow
def test_beats_the_constant_fill_on_a_real_frame(kitti_root, release):
    from estimators.classical import ConstantInpainter
    from inpaintenv.conventions import corrupt
    from inpaintenv.data import KittiDepth
    from inpaintenv.metrics import frame_metrics

    kind = SPARSE_INPUT.get(release[0])
    if kind is None:  # a map release: rect-v1's hole in the official val map
        gt = KittiDepth(kitti_root, split="val")[0]
        hole = get_protocol("rect-v1").mask(gt.shape, 0, 0)
        x = corrupt(gt, hole)
    else:  # a sparse-scan release: the val frame's scan thinned, scored on the truth it did not measure
        from inpaintenv.data import method_input

        scan, gt = (a[0] for a in KittiDepth(kitti_root, split="val", input=kind).load_pairs([0]))
        x = method_input(scan, np.zeros(scan.shape, bool), "scan")
        hole = np.isnan(x) & (gt > 0)
    pred = release[1].predict(x)
    np.testing.assert_array_equal(pred[x > 0], x[x > 0])
    ours = frame_metrics(pred[None], gt[None], hole[None])["hole_rmse"][0]
    const = frame_metrics(ConstantInpainter().predict(x)[None], gt[None], hole[None])["hole_rmse"][0]
    assert ours < const
