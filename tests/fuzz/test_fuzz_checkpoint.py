"""load on tampered checkpoints: one CheckpointError, and no file written anywhere.

Each property edits a valid saved checkpoint the way an attacker or a broken disk could --
member names that are paths, NaN/inf or non-float weights, a missing checksum, config
entries of the wrong type, huge sizes -- and asserts that loading raises
:class:`CheckpointError` (nothing else: no AttributeError, TypeError, MemoryError or torch
traceback) and that no file appears outside the test's own folders.
"""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path
from typing import Any

import pytest
import torch
from fuzz_settings import fast
from hypothesis import given
from hypothesis import strategies as st

from estimators.learned import MeanEnsembleInpainter
from estimators.learned._checkpoint import CheckpointError, read_checkpoint, write_checkpoint
from estimators.learned._checkpoint_checks import PATH_PARAMS
from estimators.learned import BlendInpainter
from estimators.learned import load
from estimators.learned import UNetInpainter
from estimators.learned import PriorUNetInpainter
from inpaintenv.data import SyntheticStreets

from fifo_checks import returns_within

FAMILIES = ("blend", "ensemble", "unet", "prior")


@pytest.fixture(scope="module")
def saved(tmp_path_factory) -> dict[str, tuple[dict[str, Any], dict[str, torch.Tensor]]]:
    """The config and weights of one small saved model of each family."""
    frames = SyntheticStreets(n=4, frame_shape=(32, 64), frames_per_drive=2)
    root = tmp_path_factory.mktemp("fuzz-saved")
    blend = dict(width=4, layers=1, epochs=1, masks_per_frame=1, pixels_per_frame=100, batch_pixels=64,
                 num_threads=1, tta=False)
    a, b = BlendInpainter(**blend).fit(frames), BlendInpainter(**blend, random_state=1).fit(frames)
    folders = {
        "blend": a.save(root / "blend"),
        "ensemble": MeanEnsembleInpainter.from_fitted([("first", a), ("second", b)]).save(root / "ensemble"),
        "unet": UNetInpainter(width=4, depth=1, batch_size=2, max_steps=1, random_state=0,
                              num_threads=1).fit(frames).save(root / "unet"),
        "prior": PriorUNetInpainter(width=4, levels=1, batch_size=2, max_steps=1, random_state=0,
                                    num_threads=1).fit(frames).save(root / "prior"),
    }
    out = {}
    for name, folder in folders.items():
        config, weights, _, _ = read_checkpoint(folder)
        out[name] = ({k: v for k, v in config.items() if k != "weights_sha256"}, weights)
    return out


@pytest.fixture
def sandbox(tmp_path, monkeypatch) -> Path:
    """A folder for the tampered checkpoint, with Python's temporary files kept inside it."""
    temp = tmp_path / "a" / "b"
    temp.mkdir(parents=True)
    monkeypatch.setattr(tempfile, "tempdir", str(temp))
    return tmp_path


def _files(root: Path) -> set[Path]:
    return set(root.rglob("*"))


def _refused(folder: Path, sandbox: Path, *also_absent: Path) -> CheckpointError:
    """Load ``folder``: assert one CheckpointError and that nothing was written."""
    before = _files(sandbox)
    with pytest.raises(CheckpointError) as info:
        load(folder)
    assert _files(sandbox) == before
    assert not any(p.exists() for p in also_absent)
    assert "\n" not in str(info.value)  # one line
    return info.value


def _write(folder: Path, config: dict[str, Any], weights: dict[str, torch.Tensor]) -> Path:
    return write_checkpoint(folder, config, weights)


path_names = st.one_of(
    st.sampled_from(["../../x", "..", ".", "/", "a/b", "a\\b", "../x", "x/..", "a.b", "", " ", "_a", "a__b",
                     "1a", "a-b", "é", "a\x00b"]),
    st.text(st.sampled_from("ab./\\_-0 "), min_size=1, max_size=8).filter(lambda s: "/" in s or "." in s),
)


@fast(25)
@given(name=path_names, which=st.integers(0, 1), absolute=st.booleans())
def test_member_names_that_are_not_identifiers_write_nothing(saved, sandbox, name, which, absolute):
    config, weights = saved["ensemble"]
    victim = sandbox / "victim" / "dir"
    bad = str(victim) if absolute else name
    members = [dict(m) for m in config["members"]]
    members[which]["name"] = bad
    folder = _write(sandbox / "ckpt", {**config, "members": members}, weights)
    message = str(_refused(folder, sandbox, victim, victim.parent, sandbox / "a" / "x"))
    assert "name" in message


@fast(20)
@given(family=st.sampled_from(FAMILIES), value=st.sampled_from([float("nan"), float("inf"), -float("inf")]),
       pick=st.integers(0, 10**6), where=st.integers(0, 10**6))
def test_non_finite_weights_are_refused_naming_the_tensor(saved, sandbox, family, value, pick, where):
    config, weights = saved[family]
    key = sorted(weights)[pick % len(weights)]
    w = weights[key].clone()
    w.view(-1)[where % w.numel()] = value
    folder = _write(sandbox / "ckpt", config, {**weights, key: w})
    message = str(_refused(folder, sandbox))
    assert f"tensor {key!r} holds NaN or inf" in message and "model.safetensors" in message


@fast(20)
@given(family=st.sampled_from(FAMILIES),
       dtype=st.sampled_from([torch.int8, torch.int16, torch.int32, torch.int64, torch.uint8, torch.bool]),
       pick=st.integers(0, 10**6))
def test_weights_that_are_not_floating_point_are_refused(saved, sandbox, family, dtype, pick):
    config, weights = saved[family]
    key = sorted(weights)[pick % len(weights)]
    folder = _write(sandbox / "ckpt", config, {**weights, key: weights[key].to(dtype)})
    message = str(_refused(folder, sandbox))
    assert f"tensor {key!r} has dtype {str(dtype).removeprefix('torch.')}" in message


@fast(8)
@given(family=st.sampled_from(FAMILIES), replacement=st.sampled_from([None, "", 0, "0" * 64]))
def test_a_missing_or_false_checksum_is_refused(saved, sandbox, family, replacement):
    config, weights = saved[family]
    folder = _write(sandbox / "ckpt", config, weights)
    path = folder / "config.json"
    stored = json.loads(path.read_text())
    if replacement is None:
        del stored["weights_sha256"]
    else:
        stored["weights_sha256"] = replacement
    path.write_text(json.dumps(stored))
    _refused(folder, sandbox)


json_values = st.one_of(st.none(), st.booleans(), st.integers(-3, 3), st.floats(allow_nan=False), st.text(max_size=5),
                        st.lists(st.integers(0, 3), max_size=3), st.dictionaries(st.text(max_size=3), st.integers(), max_size=2))
KEYS = {
    "blend": ["params", "model_params", "fit", "class", "format_version"],
    "ensemble": ["params", "members", "fit", "class"],
    "unet": ["params", "fitted", "seed", "class"],
    "prior": ["params", "fitted", "seed", "format_version"],
}


@fast(40)
@given(family=st.sampled_from(FAMILIES), data=st.data())
def test_config_entries_of_the_wrong_type_are_one_checkpoint_error(saved, sandbox, family, data):
    config, weights = saved[family]
    key = data.draw(st.sampled_from(KEYS[family]))
    # null is a valid "absent" for the optional sections (shipped releases record "fitted": null).
    optional = key in ("fit", "fitted", "seed")
    value = data.draw(json_values.filter(lambda v: type(v) is not type(config.get(key)) and not (optional and v is None)))
    folder = _write(sandbox / "ckpt", {**config, key: value}, weights)
    _refused(folder, sandbox)


@fast(30)
@given(family=st.sampled_from(("blend", "prior", "unet")), data=st.data())
def test_huge_sizes_are_refused_before_anything_is_allocated(saved, sandbox, family, data):
    config, weights = saved[family]
    key = data.draw(st.sampled_from({"blend": ["width", "layers"], "prior": ["width", "levels"],
                                     "unet": ["width", "depth"]}[family]))
    value = data.draw(st.integers(10**4, 10**12))
    folder = _write(sandbox / "ckpt", {**config, "params": {**config["params"], key: value}}, weights)
    message = str(_refused(folder, sandbox))
    assert key in message and "allowed" in message


@fast(10)
@given(member=st.integers(0, 1), key=st.sampled_from(["width", "layers"]), value=st.integers(10**5, 10**12))
def test_huge_sizes_of_an_ensemble_member_are_refused(saved, sandbox, member, key, value):
    config, weights = saved["ensemble"]
    members = [json.loads(json.dumps(m)) for m in config["members"]]
    members[member]["config"]["params"][key] = value
    folder = _write(sandbox / "ckpt", {**config, "members": members}, weights)
    message = str(_refused(folder, sandbox))
    assert f"member {members[member]['name']!r}" in message and f"{key}={value}" in message


# -- paths, threads and hostile files in a checkpoint ---------------------------
def _with_paths(params: dict[str, Any], target: Path, names: tuple[str, ...] = PATH_PARAMS) -> dict[str, Any]:
    return {**params, **{k: str(target) for k in names if k in params}}


def _every_params(est: Any) -> list[tuple[str, dict[str, Any]]]:
    """The parameters of ``est`` and of each fitted member of an ensemble."""
    out = [(type(est).__name__, est.get_params(deep=False))]
    for member in getattr(est, "estimators_", []):
        out += _every_params(member)
    return out


def test_every_parameter_that_names_a_file_is_listed():
    import inspect

    from estimators.learned._load import LOADABLE

    assert len(LOADABLE) >= 6
    for name, klass in LOADABLE.items():
        params = inspect.signature(klass.__init__).parameters
        pathlike = {p for p in params if p == "warm_start" or p.endswith(("_dir", "_path", "_file", "_root"))}
        assert pathlike <= set(PATH_PARAMS), (name, pathlike - set(PATH_PARAMS))


@pytest.mark.parametrize("family", FAMILIES)
def test_paths_in_a_loaded_checkpoint_are_never_kept(saved, sandbox, family):
    config, weights = saved[family]
    config = json.loads(json.dumps(config))
    elsewhere = sandbox / "elsewhere"
    config["params"] = _with_paths(config["params"], elsewhere)
    for member in config.get("members", []):
        member["config"]["params"] = _with_paths(member["config"]["params"], elsewhere)
    est = load(_write(sandbox / "ckpt", config, weights))
    for name, params in _every_params(est):
        kept = {k: v for k, v in params.items() if k in PATH_PARAMS and v is not None and not isinstance(v, bool)}
        assert not kept, (name, kept)


@pytest.mark.parametrize("family", ["unet", "prior"])
def test_a_later_fit_of_a_loaded_model_writes_nothing_where_the_file_said(saved, sandbox, family):
    config, weights = saved[family]
    elsewhere = sandbox / "elsewhere"
    assert "checkpoint_dir" in config["params"]
    config = {**config, "params": _with_paths(config["params"], elsewhere, ("checkpoint_dir",))}
    est = load(_write(sandbox / "ckpt", config, weights))
    assert est.checkpoint_dir is None
    est.set_params(max_steps=1).fit(SyntheticStreets(n=2, frame_shape=(32, 64), frames_per_drive=1))
    assert not elsewhere.exists()


@pytest.mark.parametrize("family", FAMILIES)
def test_thread_counts_beyond_the_limit_are_one_checkpoint_error(saved, sandbox, family):
    config, weights = saved[family]
    folder = _write(sandbox / "ckpt", {**config, "params": {**config["params"], "num_threads": 1000}}, weights)
    message = str(_refused(folder, sandbox))
    assert "num_threads=1000" in message and "allowed" in message


@pytest.mark.parametrize("family", FAMILIES)
def test_a_checkpoint_never_starts_more_threads_than_the_machine_has_cores(saved, sandbox, family, monkeypatch):
    config, weights = saved[family]
    params = {**config["params"], "num_threads": 300}
    if "predict_threads" in params:
        params["predict_threads"] = 300
    est = load(_write(sandbox / "ckpt", {**config, "params": params}, weights))
    asked: list[int] = []
    real = torch.set_num_threads
    monkeypatch.setattr(torch, "set_num_threads", lambda n: (asked.append(n), real(n))[1])
    x = SyntheticStreets(n=1, frame_shape=(32, 64), frames_per_drive=1)[0].copy()
    x[8:20, 10:40] = float("nan")
    est.predict(x)
    assert asked and max(asked) <= (os.cpu_count() or 1)


def test_deeply_nested_config_is_one_checkpoint_error(saved, sandbox):
    config, weights = saved["unet"]
    folder = _write(sandbox / "ckpt", config, weights)
    (folder / "config.json").write_text("[" * 100_000 + "]" * 100_000)
    assert "nested" in str(_refused(folder, sandbox))
    run = sandbox / "run"
    run.mkdir()
    (run / "state.json").write_text('{"last": ' * 50_000 + "1" + "}" * 50_000)
    with pytest.raises(CheckpointError, match="nested"):
        load(run)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
@pytest.mark.parametrize("name", ["config.json", "model.safetensors"])
def test_a_fifo_in_a_checkpoint_is_refused_at_once(saved, sandbox, name):
    config, weights = saved["blend"]
    folder = _write(sandbox / "ckpt", config, weights)
    (folder / name).unlink()
    os.mkfifo(folder / name)
    error = returns_within(10, lambda: load(folder), folder / name)
    assert isinstance(error, CheckpointError) and "FIFO" in str(error), error


def test_saving_replaces_a_planted_link_and_never_writes_through_it(saved, sandbox):
    config, weights = saved["blend"]
    victim = sandbox / "victim.json"
    victim.write_text("keep me")
    folder = sandbox / "ckpt"
    folder.mkdir()
    for name in ("config.json", "model.safetensors"):
        (folder / name).symlink_to(victim)
    _write(folder, config, weights)
    assert victim.read_text() == "keep me"
    assert not any(p.is_symlink() for p in folder.iterdir())
    load(folder)


def test_a_resuming_run_never_reads_its_state_through_a_link(sandbox):
    from estimators.learned._checkpoint import read_run_state

    elsewhere = sandbox / "elsewhere.json"
    elsewhere.write_text('{"last": "ckpt-1", "best": null}')
    run = sandbox / "run"
    run.mkdir()
    (run / "state.json").symlink_to(elsewhere)
    assert read_run_state(run) == {"last": "ckpt-1", "best": None}  # a folder handed to load: as given
    with pytest.raises(CheckpointError, match="symbolic link"):
        read_run_state(run, owned=True)


def test_a_release_override_beyond_the_thread_limit_is_refused_at_load():
    from estimators.learned import load_release
    from inpaintenv.exceptions import InvalidInputError

    with pytest.raises(InvalidInputError, match="num_threads=1000"):
        load_release("kitti-mixed-v1", num_threads=1000)
