"""Tampered checkpoints are refused at load with one CheckpointError, and loading never writes
a file or reads outside the checkpoint."""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

import pytest
import torch
from streets import streets as _streets

from estimators.learned import MeanEnsembleInpainter
from estimators.learned import _limits
from estimators.learned._checkpoint import CheckpointError, read_checkpoint, write_checkpoint
from estimators.learned import BlendInpainter
from estimators.learned import ContextBlendInpainter
from estimators.learned import load, load_release
from estimators.learned import UNetInpainter
from estimators.learned import PriorUNetInpainter
from inpaintenv.data import ArrayDataset
from inpaintenv.methods.registry import make_method

BLEND = dict(width=8, layers=1, epochs=1, masks_per_frame=1, pixels_per_frame=200, batch_pixels=64, num_threads=1,
             tta=False)
CONTEXT = dict(n_context=2, context_widths=(4, 8), width=8, layers=1, epochs=1, masks_per_frame=1, keep=(1.0,),
               pixels_per_frame=200, batch_frames=3, batch_pixels=64, num_threads=1)
UNET = dict(width=4, depth=2, batch_size=2, epochs=1, random_state=0, num_threads=1)
PRIOR = dict(width=4, levels=1, batch_size=2, max_steps=2, random_state=0, num_threads=1)


@pytest.fixture(scope="module")
def data() -> ArrayDataset:
    return ArrayDataset(_streets(), groups=list("aaaabc"))


@pytest.fixture(scope="module")
def saved(data, tmp_path_factory) -> dict[str, Path]:
    """One saved checkpoint of each learned family (read-only: tests tamper with copies)."""
    root = tmp_path_factory.mktemp("saved")
    context = ContextBlendInpainter(**CONTEXT).fit(data)
    blend = BlendInpainter(**BLEND).fit(data)
    return {
        "blend": blend.save(root / "blend"),
        "context": context.save(root / "context"),
        "ensemble": MeanEnsembleInpainter.from_fitted([("context", context), ("blend", blend)]).save(root / "ens"),
        "unet": UNetInpainter(**UNET).fit(data).save(root / "unet"),
        "prior": PriorUNetInpainter(**PRIOR).fit(data).save(root / "prior"),
    }


def _rewrite(source: Path, target: Path, *, config=None, weights=None) -> Path:
    """A copy of checkpoint ``source`` with its config and/or weights edited (checksum recomputed)."""
    old_config, old_weights, _, _ = read_checkpoint(source)
    new_config = {k: v for k, v in old_config.items() if k != "weights_sha256"}
    return write_checkpoint(target, config(new_config) if config else new_config,
                            weights(old_weights) if weights else old_weights)


def _edit_json(folder: Path, edit) -> Path:
    """``folder``'s config.json edited in place (its weights checksum untouched)."""
    path = folder / "config.json"
    path.write_text(json.dumps(edit(json.loads(path.read_text()))))
    return folder


def _files_under(root: Path) -> set[Path]:
    return {p for p in root.rglob("*")}


# -- member names are never paths --------------------------------------------------
@pytest.mark.parametrize("kind", ["absolute", "parent"])
def test_member_names_that_are_paths_are_refused_and_nothing_is_written(saved, tmp_path, monkeypatch, kind):
    # The loader's own temporary folders (if any) go under tmp_path/a/b, so "../../x" lands
    # in tmp_path/a/x and an absolute name in tmp_path/outside: both must stay absent.
    temp_root = tmp_path / "a" / "b"
    temp_root.mkdir(parents=True)
    monkeypatch.setattr(tempfile, "tempdir", str(temp_root))
    target = tmp_path / "outside" / "dir" if kind == "absolute" else tmp_path / "a" / "x"
    name = str(target) if kind == "absolute" else "../../x"
    folder = _rewrite(saved["ensemble"], tmp_path / "ens",
                      config=lambda c: {**c, "members": [{**c["members"][0], "name": name}, c["members"][1]]})
    before = _files_under(tmp_path)
    with pytest.raises(CheckpointError, match=r"'members'\[0\] has name .*letters, digits and single underscores"):
        load(folder)
    assert not target.exists() and not target.parent.exists() if kind == "absolute" else not target.exists()
    assert _files_under(tmp_path) == before  # nothing written anywhere under the test's folder


def test_an_ensemble_loads_without_writing_any_file(saved, tmp_path, monkeypatch):
    temp_root = tmp_path / "temp"
    temp_root.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(temp_root))
    writes = []
    monkeypatch.setattr("estimators.learned._checkpoint.write_checkpoint",
                        lambda *a, **k: writes.append(a) or pytest.fail("load wrote a checkpoint"))
    assert isinstance(load(saved["ensemble"]), MeanEnsembleInpainter)
    assert writes == [] and list(temp_root.iterdir()) == []


@pytest.mark.parametrize("last", ["absolute", "../outside", "ckpt-1/../../outside", None, 3])
def test_a_run_folder_pointer_outside_the_folder_is_refused(saved, tmp_path, last):
    run = tmp_path / "run"
    run.mkdir()
    pointer = str(saved["unet"]) if last == "absolute" else last
    (run / "state.json").write_text(json.dumps({"last": pointer, "best": None}))
    with pytest.raises(CheckpointError, match=r"state.json: 'last' must name a checkpoint folder of this run"):
        UNetInpainter.load(run)
    (run / "state.json").write_text(json.dumps({"last": "ckpt-00000001-abc", "best": "/etc"}))
    with pytest.raises(CheckpointError, match=r"'best' must name a checkpoint folder of this run .*got '/etc'"):
        load(run)


def test_a_resume_from_a_tampered_run_folder_is_refused(data, tmp_path):
    est = UNetInpainter(**UNET, checkpoint_dir=tmp_path / "runs").fit(data)
    elsewhere = est.save(tmp_path / "elsewhere")
    (est.run_dir_ / "state.json").write_text(json.dumps({"last": str(elsewhere), "best": None}))
    with pytest.raises(CheckpointError, match=r"'last' must name a checkpoint folder of this run"):
        UNetInpainter(**UNET, checkpoint_dir=tmp_path / "runs").fit(data)


# -- weights --------------------------------------------------------------
def _first_key(weights: dict[str, torch.Tensor]) -> str:
    return sorted(weights)[0]


def _set_first(weights, value):
    key = _first_key(weights)
    w = weights[key].clone()
    w.view(-1)[0] = value
    return {**weights, key: w}


@pytest.mark.parametrize("family", ["blend", "ensemble", "unet", "prior"])
@pytest.mark.parametrize("bad, message", [
    (lambda w: _set_first(w, float("nan")), r"model.safetensors: tensor '.+' holds NaN or inf values"),
    (lambda w: _set_first(w, float("inf")), r"model.safetensors: tensor '.+' holds NaN or inf values"),
    (lambda w: {**w, _first_key(w): w[_first_key(w)].to(torch.int32)}, r"tensor '.+' has dtype int32; network weights are floating point"),
    (lambda w: {**w, _first_key(w): w[_first_key(w)] > 0}, r"tensor '.+' has dtype bool"),
], ids=["nan", "inf", "int32", "bool"])
def test_bad_weights_are_refused_naming_the_file_and_tensor(saved, tmp_path, family, bad, message):
    folder = _rewrite(saved[family], tmp_path / family, weights=bad)
    with pytest.raises(CheckpointError, match=message):
        load(folder)


@pytest.mark.parametrize("family", ["blend", "ensemble", "unet"])
def test_weights_without_a_recorded_checksum_are_refused(saved, tmp_path, family):
    folder = _rewrite(saved[family], tmp_path / family)
    # Edited weights and a config without the checksum that would catch the edit.
    _, weights, _, _ = read_checkpoint(folder)
    write_checkpoint(tmp_path / "edited", {}, _set_first(weights, 123.0))
    (folder / "model.safetensors").write_bytes((tmp_path / "edited" / "model.safetensors").read_bytes())
    _edit_json(folder, lambda c: {k: v for k, v in c.items() if k != "weights_sha256"})
    with pytest.raises(CheckpointError, match=r"config.json records no SHA-256 of model.safetensors "
                                              r"\(key 'weights_sha256'\): the file cannot be verified"):
        load(folder)


# -- the unclear messages: config entries of the wrong type -----------------------
@pytest.mark.parametrize("family, edit, message", [
    ("unet", lambda c: {**c, "fitted": "abc"}, r"'fitted' must be a JSON object, got 'abc'"),
    ("unet", lambda c: {**c, "fitted": {**c["fitted"], "n_steps_": "12"}}, r"'n_steps_' must be an integer"),
    ("unet", lambda c: {**c, "params": None}, r"config.json has no 'params' \(a JSON object\)"),
    ("unet", lambda c: {**c, "params": [1, 2]}, r"'params' must be a JSON object, got \[1, 2\]"),
    ("unet", lambda c: {**c, "seed": "zero"}, r"'seed' must be an integer"),
    ("unet", lambda c: {**c, "format_version": "1"}, r"'format_version' must be an integer"),
    ("prior", lambda c: {**c, "fitted": [1]}, r"'fitted' must be a JSON object"),
    ("blend", lambda c: {k: v for k, v in c.items() if k != "model_params"}, r"has no 'model_params'"),
    ("blend", lambda c: {**c, "fit": "abc"}, r"'fit' must be a JSON object"),
    ("blend", lambda c: {**c, "params": None}, r"has no 'params'"),
    ("blend", lambda c: {**c, "params": {**c["params"], "candidates": "scanline"}}, r"'candidates' must be a list"),
    ("ensemble", lambda c: {**c, "members": ["a", "b"]}, r"'members'\[0\] must be a JSON object with 'name' and 'config'"),
    ("ensemble", lambda c: {**c, "members": "ab"}, r"'members' must be a list"),
    ("ensemble", lambda c: {**c, "members": c["members"][:1]}, r"'members' must list at least two members, got 1"),
    ("ensemble", lambda c: {**c, "members": [c["members"][0], c["members"][0]]}, r"names member 'context' twice"),
    ("ensemble", lambda c: {**c, "members": [{"name": "context"}, c["members"][1]]},
     r"\(member 'context'\): config.json has no 'config'"),
    ("ensemble", lambda c: {**c, "params": None}, r"has no 'params'"),
    ("ensemble", lambda c: {**c, "fit": {"fit_seconds": "fast"}}, r"'fit_seconds' must be a number"),
], ids=['unet-fitted-str', 'unet-n_steps-str', 'unet-params-null', 'unet-params-list', 'unet-seed-str', 'unet-format_version-str', 'prior-fitted-list', 'blend-no-model_params', 'blend-fit-str', 'blend-params-null', 'blend-candidates-str', 'ensemble-members-str-items', 'ensemble-members-str', 'ensemble-one-member', 'ensemble-name-twice', 'ensemble-member-no-config', 'ensemble-params-null', 'ensemble-fit_seconds-str'])
def test_config_entries_of_the_wrong_type_are_one_checkpoint_error(saved, tmp_path, family, edit, message):
    folder = _rewrite(saved[family], tmp_path / family, config=edit)
    with pytest.raises(CheckpointError, match=message):
        load(folder)


def test_a_checkpoint_without_params_is_named_through_the_registry(saved, tmp_path):
    folder = _rewrite(saved["unet"], tmp_path / "unet", config=lambda c: {**c, "params": None})
    with pytest.raises(CheckpointError, match=r"unet: config.json has no 'params'"):
        make_method("checkpoint", path=str(folder))


def test_a_run_folder_without_last_names_the_key(tmp_path):
    (tmp_path / "state.json").write_text("{}")
    with pytest.raises(CheckpointError, match=r"state.json: 'last' must name a checkpoint folder .*got None"):
        UNetInpainter.load(tmp_path)


# -- sizes are bounded before anything is allocated --------------------------------
@pytest.mark.parametrize("family, edit, message", [
    ("blend", lambda c: {**c, "params": {**c["params"], "width": 10**5}}, r"width=100000 is more than the 4096 allowed"),
    ("blend", lambda c: {**c, "params": {**c["params"], "layers": 10**6}}, r"layers=1000000 is more than the 64 allowed"),
    ("context", lambda c: {**c, "params": {**c["params"], "n_members": 10**7}},
     r"n_members=10000000 is more than the 64 allowed"),
    ("context", lambda c: {**c, "params": {**c["params"], "context_widths": [10**6]}},
     r"max\(context_widths\)=1000000 is more than the 4096 allowed"),
    ("prior", lambda c: {**c, "params": {**c["params"], "levels": 10**6}}, r"levels=1000000 is more than the 64 allowed"),
    ("prior", lambda c: {**c, "params": {**c["params"], "width": 4096, "levels": 60}},
     r"gives a network of [\d,]+ parameters, more than the 200,000,000 allowed"),
    ("unet", lambda c: {**c, "params": {**c["params"], "depth": 10**6}}, r"depth=1000000 gives astronomically many"),
], ids=["blend-width", "blend-layers", "context-members", "context-widths", "prior-levels", "prior-parameters",
        "unet-depth"])
def test_huge_sizes_in_a_checkpoint_are_refused_before_allocating(saved, tmp_path, family, edit, message):
    folder = _rewrite(saved[family], tmp_path / family, config=edit)
    with pytest.raises(CheckpointError, match=message):
        load(folder)


@pytest.mark.parametrize("est, message", [
    (BlendInpainter(width=10**5), r"width=100000 is more than the 4096 allowed"),
    (BlendInpainter(width=4096, layers=64), r"parameters, more than the 200,000,000 allowed"),
    (ContextBlendInpainter(n_members=10**7), r"n_members=10000000 is more than the 64 allowed"),
    (PriorUNetInpainter(levels=10**6), r"levels=1000000 is more than the 64 allowed"),
    (PriorUNetInpainter(arch="unet", factor=10**4, levels=1, width=4), r"parameters, more than the 200,000,000"),
], ids=["blend-width", "blend-parameters", "context-members", "prior-levels", "prior-unet-factor"])
def test_huge_sizes_as_parameters_are_refused_at_fit(data, est, message):
    with pytest.raises(ValueError, match=message):
        est.fit(data)


def test_the_limits_are_far_above_the_shipped_releases():
    est = load_release("kitti-ensemble-v1")
    for member in est.estimators_:
        n = sum(p.numel() for p in member.model_.parameters())
        assert n < _limits.MAX_PARAMETERS / 100


def test_members_of_every_family_are_rebuilt_in_memory_as_they_were_saved(saved, tmp_path):
    members = [("prior", load(saved["prior"])), ("unet", load(saved["unet"])),
               ("blend", load(saved["blend"]))]
    ensemble = MeanEnsembleInpainter.from_fitted(members)
    loaded = load(ensemble.save(tmp_path / "ens"))
    assert loaded.named_estimators_["prior"].candidates == members[0][1].candidates
    assert isinstance(loaded.named_estimators_["prior"].candidates, tuple)
    x = _streets(1, seed=3)[0]
    x[10:25, 30:70] = float("nan")
    assert (loaded.predict(x) == ensemble.predict(x)).all()
