"""Every method name and checkpoint of a run is checked before any scoring."""

from __future__ import annotations

import json

import pytest

from inpaintenv.cli import main
from inpaintenv.cli.method_options import (
    check_checkpoint_folder,
    check_method_names,
    parse_checkpoints,
)

classical = pytest.importorskip("estimators.classical")

SMALL = ["--frame-shape", "32", "96", "--n-frames", "4", "--holdout", "0", "--figure-frames", "0", "--quiet"]


@pytest.fixture
def never_scored(monkeypatch):
    """Fails the test if any classical method predicts (i.e. work started)."""
    def predict(self, X):
        raise AssertionError("a method was scored before the arguments were checked")

    for cls in (classical.ScanlineInpainter, classical.ConstantInpainter):
        monkeypatch.setattr(cls, "predict", predict)


def test_checkpoint_file_instead_of_folder_is_refused_before_scoring(tmp_path, capsys, never_scored):
    model = tmp_path / "model"
    model.mkdir()
    (model / "model.safetensors").write_bytes(b"x")
    (model / "config.json").write_text("{}")
    argv = ["benchmark", "-m", "scanline", "-m", "constant", "--checkpoint", f"mine={model / 'model.safetensors'}",
            *SMALL, "--out", str(tmp_path / "out")]
    assert main(argv) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1
    assert f"is a file, not a checkpoint folder (pass its folder {model})" in err
    assert "a checkpoint folder holds model.safetensors and config.json" in err


@pytest.mark.parametrize("bad, message", [
    (["--protocol", "nope"], "nope"),
    (["--seed", "-1"], "--seed"),
    (["-m", "nope"], "unknown method"),
    (["-m", "no_such_module:Thing"], "no_such_module"),
    (["--drives", "2011_nope"], "unknown drives"),
    (["--batch-size", "0"], "--batch-size"),
    (["--checkpoint", "mine=/no/such/folder"], "checkpoint not found"),
])
def test_every_argument_is_checked_before_scoring(tmp_path, capsys, never_scored, bad, message):
    argv = ["benchmark", "-m", "scanline", *SMALL, *bad, "--out", str(tmp_path / "out")]
    assert main(argv) == 1
    assert message in capsys.readouterr().err


def test_out_that_is_a_file_is_refused(tmp_path, capsys, never_scored):
    f = tmp_path / "results"
    f.write_text("")
    assert main(["benchmark", "-m", "scanline", *SMALL, "--out", str(f)]) == 1
    assert "is a file" in capsys.readouterr().err


def test_checkpoint_without_a_path_points_at_the_option(tmp_path, capsys):
    for cmd in (["evaluate", "-m", "checkpoint", "--n-frames", "2"], ["benchmark", "-m", "checkpoint", *SMALL]):
        assert main([*cmd, "--out", str(tmp_path / "o")]) == 1
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and "--checkpoint NAME=PATH" in err and "missing 1 required" not in err


def test_evaluate_takes_checkpoint_name_path(tmp_path, capsys):
    pytest.importorskip("torch")
    import numpy as np

    from estimators.learned import UNetInpainter
    from inpaintenv.data import ArrayDataset

    frames = np.stack([np.linspace(30.0, 5.0, 32, dtype=np.float32)[:, None] + np.zeros((1, 96), np.float32)] * 2)
    model = UNetInpainter(width=4, depth=2, batch_size=2, epochs=1, random_state=0, num_threads=1)
    path = model.fit(ArrayDataset(frames, groups=["a", "b"])).save(tmp_path / "ck")
    args = ["evaluate", "-m", "constant", "--checkpoint", f"mine={path}", "--frame-shape", "32", "96",
            "--n-frames", "2", "--quiet"]
    # A one-epoch model's raw output is 0 m in places; learned methods floor hole pixels at
    # 1/256 m, so it is scored as an estimate, not refused as unfilled.
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "| mine | rect-v1 |" in out and "| constant | rect-v1 |" in out


def test_check_helpers(monkeypatch):
    from inpaintenv.methods import registry

    monkeypatch.setitem(registry._ALIASES, "my-default", "pretrained")
    assert check_method_names(["my-default", "scanline"]) == ["pretrained", "scanline"]
    with pytest.raises(ValueError, match="given twice"):
        check_method_names(["my-default", "pretrained"])
    with pytest.raises(ValueError, match="NAME=PATH"):
        parse_checkpoints(["mine"])


def test_checkpoint_folder_checks(tmp_path):
    with pytest.raises(ValueError, match="is not a checkpoint folder"):
        check_checkpoint_folder(tmp_path)
    (tmp_path / "state.json").write_text(json.dumps({"last": "x"}))  # a training run folder
    assert check_checkpoint_folder(tmp_path) == tmp_path
    with pytest.raises(ValueError, match="used twice"):
        parse_checkpoints([f"a={tmp_path}", f"a={tmp_path}"])
    with pytest.raises(ValueError, match="used twice"):
        parse_checkpoints([f"scanline={tmp_path}"], taken=["scanline"])


def test_synthetic_holdout_error_says_holdout_0_scores_all_frames(tmp_path, capsys):
    assert main(["benchmark", "-m", "harmonic", "--n-frames", "4", "--frame-shape", "32", "96",
                 "--figure-frames", "0", "--quiet", "--out", str(tmp_path)]) == 1
    err = capsys.readouterr().err
    assert "a drive-level split needs at least 2 drives" in err and "pass --holdout 0 to score all frames" in err
