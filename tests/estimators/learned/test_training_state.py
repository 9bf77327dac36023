"""A training state is resumed only when it is checksummed, well formed and agrees with its
checkpoint and the fit resuming it; a write that fails (a full disk) leaves no checkpoint folder.

Each refusal is one ``CheckpointError`` naming ``training.json`` (or the file at fault) and
the disagreement, raised before a step is trained; the run folder is left as it was.
"""

from __future__ import annotations

import errno
import hashlib
import json
import shutil
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import torch
from safetensors import SafetensorError
from safetensors.torch import load_file, save_file
from streets import streets as _streets

from estimators.learned import PriorUNetInpainter, UNetInpainter
from estimators.learned import _checkpoint
from inpaintenv.data import ArrayDataset
from inpaintenv.exceptions import CheckpointError, RunLockedError

#: A pixel PriorUNet (Cosine schedule, several Adam updates a step) and a U-Net (constant
#: rate, one update a step, validation): 6 small frames, a checkpoint every step.
PRIOR = dict(arch="pixel", width=8, levels=1, batch_size=2, max_steps=5, epochs=100, num_threads=1, random_state=0,
             checkpoint_every=1)
UNET = dict(width=4, depth=2, batch_size=2, epochs=3, num_threads=1, random_state=0, checkpoint_every=1,
            validation_fraction=0.3)
STOP_AT = 4  # steps taken before the interruption (the U-Net: mid-epoch 2 of 3 steps each)
FULL_DISK = "Error while serializing: I/O error: No space left on device (os error 28)"


class _Stop(Exception):
    """The interruption of a run (a kill, as the tests see it)."""


@pytest.fixture(scope="module")
def data() -> ArrayDataset:
    return ArrayDataset(_streets(), groups=list("aaaabc"))


def _interrupted(klass: type, params: dict[str, Any], data: ArrayDataset, root: Path, at: int = STOP_AT) -> Path:
    """The run folder of a fit stopped after ``at`` steps (each checkpointed)."""
    original = klass._train_step
    taken = [0]

    def step(self, *args):
        taken[0] += 1
        if taken[0] > at:
            raise _Stop
        return original(self, *args)

    est = klass(**params, checkpoint_dir=root)
    with pytest.MonkeyPatch.context() as mp:  # restores the class as it was (the method inherited, not its own)
        mp.setattr(klass, "_train_step", step)
        with pytest.raises(_Stop):
            est.fit(data)
    return est.run_dir_


@pytest.fixture(scope="module")
def runs(data, tmp_path_factory) -> dict[str, Path]:
    """A stopped run of each family (read-only: tests resume copies)."""
    root = tmp_path_factory.mktemp("runs")
    return {"prior": _interrupted(PriorUNetInpainter, PRIOR, data, root / "prior"),
            "unet": _interrupted(UNetInpainter, UNET, data, root / "unet")}


FAMILIES = {"prior": (PriorUNetInpainter, PRIOR), "unet": (UNetInpainter, UNET)}


def _copy(runs: dict[str, Path], family: str, tmp_path: Path) -> tuple[Path, Path]:
    """A copy of ``family``'s stopped run under ``tmp_path``: its checkpoint_dir and last checkpoint."""
    source = runs[family]
    root = tmp_path / "ckpt"
    shutil.copytree(source.parent, root)
    run = root / source.name
    return root, run / json.loads((run / "state.json").read_text())["last"]


def _resume(family: str, root: Path, data: ArrayDataset, **params: Any) -> Any:
    klass, base = FAMILIES[family]
    return klass(**{**base, **params}, checkpoint_dir=root).fit(data)


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _edit_json(path: Path, edit: Callable[[dict], Any]) -> None:
    doc = json.loads(path.read_text())
    edit(doc)  # in place
    path.write_text(json.dumps(doc))


def _state(ckpt: Path, edit: Callable[[dict], Any]) -> None:
    """``training.json`` edited and its checksum in ``config.json`` recomputed (an edit that passes the checksum)."""
    _edit_json(ckpt / "training.json", edit)
    _edit_json(ckpt / "config.json", lambda c: c.update(training_sha256=_sha(ckpt / "training.json")))


def _adam(ckpt: Path, edit: Callable[[dict], Any]) -> None:
    """``optimizer.safetensors`` edited and both checksums that cover it recomputed."""
    tensors = load_file(str(ckpt / "optimizer.safetensors"))
    edit(tensors)  # in place
    save_file(tensors, str(ckpt / "optimizer.safetensors"))
    _state(ckpt, lambda s: s.update(optimizer_sha256=_sha(ckpt / "optimizer.safetensors")))


def _refused(family: str, root: Path, data: ArrayDataset, match: str, **params: Any) -> None:
    """Resuming ``root`` is one CheckpointError matching ``match``; no step is taken, nothing changes."""
    before = {p: p.read_bytes() for p in root.rglob("*") if p.is_file()}
    with pytest.raises(CheckpointError, match=match):
        _resume(family, root, data, **params)
    assert {p: p.read_bytes() for p in root.rglob("*") if p.is_file()} == before


def _mul_step(tensors: dict, factor: float) -> None:
    for name in [n for n in tensors if n.endswith(".step")]:
        tensors[name] = tensors[name] * factor


# -- a state as written resumes, bit-identically ---------------------------------------------------

@pytest.mark.parametrize("family", ["prior", "unet"])
def test_a_stopped_run_resumes_to_the_uninterrupted_result(runs, data, tmp_path, family):
    klass, params = FAMILIES[family]
    full = klass(**params).fit(data)
    root, _ = _copy(runs, family, tmp_path)
    resumed = _resume(family, root, data)
    assert resumed.n_steps_ == full.n_steps_ > STOP_AT
    assert json.dumps(resumed.history_) == json.dumps(full.history_)
    for key, value in full.model_.state_dict().items():
        assert torch.equal(resumed.model_.state_dict()[key], value), key


# -- the edits: the checksum refuses them -----------------------------------------------------

@pytest.mark.parametrize("edit", [
    lambda s: s.update(step=s["step"] + 3),
    lambda s: s["optimizer"]["param_groups"][0].update(lr=50.0),
    lambda s: s.update(finished=True),
    lambda s: s["history"].update(step_loss=[0.001] * len(s["history"]["step_loss"])),
], ids=["step", "lr", "finished", "history"])
def test_an_edited_training_state_fails_its_checksum(runs, data, tmp_path, edit):
    root, ckpt = _copy(runs, "prior", tmp_path)
    _edit_json(ckpt / "training.json", edit)
    _refused("prior", root, data, r"training\.json does not match the checksum recorded in config\.json")


def test_a_run_folder_from_before_the_checksum_says_to_start_again(runs, data, tmp_path):
    root, ckpt = _copy(runs, "prior", tmp_path)
    _edit_json(ckpt / "config.json", lambda c: c.pop("training_sha256"))
    _refused("prior", root, data, r"config\.json records no SHA-256 of training\.json .*delete .*PriorUNetInpainter-")


# -- edits that pass the checksum: the state must agree with itself, its folder and this fit -----------

@pytest.mark.parametrize("family, edit, message", [
    ("prior", lambda s: s.update(step=s["step"] + 3, batch=s["batch"] + 3), r"step 7 disagrees with its checkpoint "
     r"folder ckpt-00000004-"),
    ("prior", lambda s: s["optimizer"]["param_groups"][0].update(lr=50.0), r"optimizer lr=50\.0 disagrees with this "
     r"run's lr and schedule, which give .* after \d+ updates"),
    ("unet", lambda s: s["optimizer"]["param_groups"][0].update(lr=50.0), r"optimizer lr=50\.0 .*give 0\.001 "),
    ("prior", lambda s: s["optimizer"]["param_groups"][0].update(weight_decay=0.5), r"weight_decay=0\.5 disagrees"),
    ("unet", lambda s: s["optimizer"]["param_groups"][0].update(lr=float("nan")), r"optimizer lr=nan disagrees"),
    ("unet", lambda s: s["optimizer"]["param_groups"][0].update(lr=True), r"optimizer lr=True disagrees"),
    ("unet", lambda s: s["optimizer"]["param_groups"][0].update(betas=[0.9, 2.0]), r"betas=\[0\.9, 2\.0\] disagrees"),
    ("prior", lambda s: s.update(finished=True), r"says finished at step 4, .* ends at max_steps=5"),
    ("prior", lambda s: s["history"]["step_loss"].append(0.01), r"'step_loss' has 5 entries; it must have one per "
     r"step \(4\)"),
    ("unet", lambda s: s["history"].update(val_hole_rmse=[]), r"'val_hole_rmse' has 0 entries; .*one per epoch \(1\)"),
    ("unet", lambda s: s["history"].update(best_epoch=3), r"'best_epoch' 3 is not a validated epoch"),
    ("unet", lambda s: s.update(batch=0), r"step 4 is not the 3 steps of the closed epochs plus the 0 batches"),
    ("unet", lambda s: s.update(epoch=2, epoch_start_step=6, batch=0, step=6), r"step 6 disagrees with its checkpoint"),
])
def test_a_state_that_disagrees_is_refused(runs, data, tmp_path, family, edit, message):
    root, ckpt = _copy(runs, family, tmp_path)
    _state(ckpt, edit)
    _refused(family, root, data, message)


@pytest.mark.parametrize("edit, message", [
    (lambda s: s.update(step=str(s["step"])), r"training\.json: 'step' must be an integer, got '4'"),
    (lambda s: s.update(step=-4), r"'step' is -4; a count is never negative"),
    (lambda s: s.update(step=10**30), r"step 10{30} disagrees with its checkpoint folder"),
    (lambda s: s.update(finished="yes"), r"'finished' must be true or false"),
    (lambda s: s.update(history=None), r"'history' must be an object, got None"),
    (lambda s: s.pop("optimizer"), r"the training state has no 'optimizer'"),
    (lambda s: s.update(note="x"), r"'note' is not a key of a training state"),
    (lambda s: s["history"].pop("step_loss"), r"the history has no 'step_loss'"),
    (lambda s: s["history"]["step_loss"].__setitem__(0, float("nan")), r"'step_loss'\[0\] is nan"),
    (lambda s: s["history"]["step_loss"].__setitem__(0, -1.0), r"'step_loss'\[0\] is -1\.0"),
    (lambda s: s["history"].update(epoch_loss="x"), r"'epoch_loss' must be a list of numbers"),
    (lambda s: s["optimizer"].update(param_groups=[]), r"'param_groups' must be a list of objects"),
    (lambda s: s["optimizer"].pop("scalars"), r"'optimizer' must hold 'param_groups' and 'scalars' only"),
    (lambda s: s["optimizer"]["param_groups"][0].pop("betas"), r"optimizer group 0 lacks 'betas'"),
    (lambda s: s["optimizer"]["param_groups"][0].update(params=[0]), r"optimizer params=\[0\] disagrees"),
    (lambda s: s["optimizer"]["param_groups"].append({}), r"2 optimizer parameter groups, this network has 1"),
    (lambda s: s["optimizer"].update(scalars={"x": {"step": 1}}), r"'x\.step' is not a state of Adam"),
    (lambda s: s.update(rng=[1, 2]), r"'rng' must be an object or null"),
    (lambda s: s.update(global_rng={"torch": "zz"}), r"global random state is not readable"),
], ids=["step-string", "step-negative", "step-huge", "finished-string", "history-null", "no-optimizer", "extra-key",
        "no-step-loss", "loss-nan", "loss-negative", "epoch-loss-string", "no-groups", "no-scalars", "no-betas",
        "group-params", "two-groups", "scalar-name", "rng-list", "global-rng"])
def test_a_state_of_the_wrong_form_is_one_checkpoint_error(runs, data, tmp_path, edit, message):
    root, ckpt = _copy(runs, "prior", tmp_path)
    _state(ckpt, edit)
    _refused("prior", root, data, message)


@pytest.mark.parametrize("family, edit, message", [
    ("unet", lambda t: _mul_step(t, 2), r"Adam counts 8 updates, which 4 steps of 1 update cannot give"),
    ("unet", lambda t: _mul_step(t, 0.5), r"Adam counts 2 updates, which 4 steps of 1 update do not give"),
    ("prior", lambda t: _mul_step(t, 1000), r"Adam counts \d+ updates, which 4 steps of 8 updates cannot give"),
    ("prior", lambda t: _mul_step(t, 0.5 + 1e-3), r"update count of parameter 0 is .*a whole number"),
    ("unet", lambda t: t.update({"0.exp_avg": torch.zeros(3)}), r"exp_avg of parameter 0 must be a floating-point "
     r"tensor of the parameter's shape"),
    ("unet", lambda t: t.update({"0.exp_avg_sq": -t["0.exp_avg_sq"] - 1}), r"exp_avg_sq of parameter 0 holds negative"),
    ("unet", lambda t: t.update({"0.exp_avg": t["0.exp_avg"] * float("nan")}), r"exp_avg of parameter 0 holds NaN"),
    ("unet", lambda t: t.pop("0.exp_avg"), r"Adam's state of parameter 0 has no 'exp_avg'"),
    ("unet", lambda t: t.update({"999.exp_avg": torch.zeros(1)}), r"'999\.exp_avg' is not a state of Adam over this "
     r"network's \d+ parameters"),
])
def test_adams_state_must_fit_the_network_and_the_steps(runs, data, tmp_path, family, edit, message):
    root, ckpt = _copy(runs, family, tmp_path)
    _adam(ckpt, edit)
    _refused(family, root, data, message)


def test_a_checkpoint_of_another_run_is_refused(runs, data, tmp_path):
    """A checkpoint folder of another recipe copied into this run's folder (its own name kept)."""
    root, ckpt = _copy(runs, "prior", tmp_path)
    other = _interrupted(PriorUNetInpainter, {**PRIOR, "lr": 0.01}, data, tmp_path / "other", at=STOP_AT)
    foreign = other / json.loads((other / "state.json").read_text())["last"]
    shutil.rmtree(ckpt)
    shutil.copytree(foreign, ckpt)
    _refused("prior", root, data, r"config\.json: the checkpoint was trained with lr=0\.01, this run has lr=0\.002")


def test_a_training_state_larger_than_any_is_not_read(runs, data, tmp_path):
    root, ckpt = _copy(runs, "prior", tmp_path)
    with open(ckpt / "training.json", "r+b") as f:
        f.truncate(300 * 1024 * 1024)  # sparse: no disk used
    with pytest.raises(CheckpointError, match=r"training\.json is 314,572,800 bytes, more than the"):
        _resume("prior", root, data)


def test_config_json_must_report_the_states_steps(runs, data, tmp_path):
    root, ckpt = _copy(runs, "prior", tmp_path)
    _edit_json(ckpt / "config.json", lambda c: c["fitted"].update(n_steps_=300))
    _refused("prior", root, data, r"config\.json's 'fitted' \(n_steps_, history_\) is not the training state's")


def test_state_json_pointing_at_a_best_checkpoint_is_refused(runs, data, tmp_path):
    root, ckpt = _copy(runs, "prior", tmp_path)
    ckpt.rename(ckpt.with_name("best-00000004-abcdef12"))
    _edit_json(ckpt.parent / "state.json", lambda s: s.update(last="best-00000004-abcdef12"))
    _refused("prior", root, data, r"state\.json: 'best-00000004-abcdef12' is not the name of a training checkpoint")


@pytest.mark.parametrize("linked", ["run", "checkpoint"])
def test_a_run_or_checkpoint_folder_that_links_elsewhere_is_never_read_or_written(runs, data, tmp_path, linked):
    """Through a link, a resume would read elsewhere, and the next checkpoint would be written
    there and the folders named ckpt-* there deleted."""
    root, ckpt = _copy(runs, "prior", tmp_path)
    folder = ckpt.parent if linked == "run" else ckpt
    elsewhere = tmp_path / "elsewhere"
    shutil.move(folder, elsewhere)
    (elsewhere / "ckpt-00000001-0123abcd").mkdir(exist_ok=True)  # someone's folder of that name
    folder.symlink_to(elsewhere, target_is_directory=True)
    before = sorted(str(p.relative_to(elsewhere)) for p in elsewhere.rglob("*"))
    with pytest.raises(CheckpointError, match=f"{folder.name} is a symbolic link; a training run reads and writes"):
        _resume("prior", root, data)
    assert sorted(str(p.relative_to(elsewhere)) for p in elsewhere.rglob("*")) == before


def test_a_second_fit_in_a_run_folder_in_use_is_refused(runs, data, tmp_path):
    """Two fits of one run at once would delete each other's checkpoints: the second is refused."""
    root, ckpt = _copy(runs, "prior", tmp_path)
    holder = subprocess.Popen([sys.executable, "-c", "import sys; from inpaintenv.files.lock import run_lock\n"
                               f"with run_lock({str(ckpt.parent)!r}):\n print('held', flush=True); sys.stdin.read()"],
                              stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline().strip() == "held"
        with pytest.raises(RunLockedError, match=rf"{ckpt.parent.name} is in use by another run \(pid {holder.pid} "
                                                 r".*use another checkpoint_dir"):
            _resume("prior", root, data)
    finally:
        holder.communicate("", timeout=30)
    assert _resume("prior", root, data).n_steps_ == PRIOR["max_steps"]  # free again: it resumes


# -- a full disk while a checkpoint is written ---------------------------------------------------------

def test_a_full_disk_is_one_oserror_and_leaves_no_partial_checkpoint(data, tmp_path, monkeypatch):
    calls = [0]
    real = _checkpoint.save_file

    def full_after_some(tensors, path):
        calls[0] += 1
        # Two tensor files a checkpoint, written after steps 1, 2, 3, at the end of epoch 1 (step 3) and
        # after step 4: the 9th file is the model of step 4's.
        if calls[0] == 9:
            with open(path, "wb") as f:
                f.write(b"\0" * 100)  # what a disk takes before it is full
            raise SafetensorError(FULL_DISK)
        return real(tensors, path)

    monkeypatch.setattr(_checkpoint, "save_file", full_after_some)
    est = PriorUNetInpainter(**PRIOR, checkpoint_dir=tmp_path / "ckpt")
    with pytest.raises(OSError, match=r"cannot write training checkpoint .*ckpt-00000004-[0-9a-f]+: No space left on "
                                      r"device; nothing of it was kept") as caught:
        est.fit(data)
    assert caught.value.errno == errno.ENOSPC
    run = est.run_dir_
    # The 3rd checkpoint, its pointer and the run's lock: no 4th, no temporary.
    names = sorted(p.name for p in run.iterdir())
    assert len(names) == 3 and names[0].startswith("ckpt-00000003-") and names[1:] == ["run.lock", "state.json"]
    assert json.loads((run / "state.json").read_text())["last"] == names[0]
    monkeypatch.setattr(_checkpoint, "save_file", real)
    resumed = PriorUNetInpainter(**PRIOR, checkpoint_dir=tmp_path / "ckpt").fit(data)
    full = PriorUNetInpainter(**PRIOR).fit(data)
    assert json.dumps(resumed.history_) == json.dumps(full.history_)
    for key, value in full.model_.state_dict().items():
        assert torch.equal(resumed.model_.state_dict()[key], value), key


def test_a_safetensors_error_that_is_not_io_is_still_an_oserror(tmp_path, monkeypatch):
    def broken(tensors, path):
        raise SafetensorError("Error while serializing: something else")

    monkeypatch.setattr(_checkpoint, "save_file", broken)
    with pytest.raises(OSError, match=r"cannot write checkpoint tensors .*model\.safetensors: safetensors could not "
                                      r"write the file: Error while serializing: something else"):
        _checkpoint.write_checkpoint(tmp_path / "m", {"class": "X"}, {"w": torch.zeros(2)})
    assert sorted(p.name for p in (tmp_path / "m").iterdir()) == []  # no temporary left, no config committing


def test_a_killed_checkpoint_writer_leaves_a_temporary_folder_the_next_write_clears(tmp_path):
    from inpaintenv.files import TEMP_PREFIX

    stale = tmp_path / f"{TEMP_PREFIX}999999999-0123456789abcdef"  # a writer that no longer runs
    (stale / "sub").mkdir(parents=True)
    (stale / "model.safetensors").write_bytes(b"half")
    _checkpoint.write_run_checkpoint(tmp_path, 1, {"class": "X"}, {"w": torch.zeros(2)},
                                     {"step": 1}, {}, best_is_current=False)
    assert not stale.exists()
    assert sorted(p.name.split("-")[0] for p in tmp_path.iterdir()) == ["ckpt", "state.json"]
