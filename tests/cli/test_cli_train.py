"""``inpaintenv train``: a preset end to end on tiny synthetic frames, resumable."""

from __future__ import annotations

import json
import re

import pytest

from inpaintenv.cli import main

pytest.importorskip("torch")


def test_train_smoke_preset_writes_model_log_and_curves(tmp_path, capsys):
    out = tmp_path / "run"
    argv = ["train", "--preset", "smoke", "--n-frames", "8", "--frame-shape", "64", "192",
            "--out", str(out), "--quiet"]
    assert main(argv) == 0
    assert (out / "model" / "model.safetensors").stat().st_size > 0
    log = json.loads((out / "training_log.json").read_text())
    assert log["preset"] == "smoke" and log["n_steps"] == 2
    assert len(log["history"]["step_loss"]) == 2
    assert (out / "loss.png").stat().st_size > 1000
    # The saved model loads and scores through the benchmark.
    bench = tmp_path / "bench"
    assert main(["benchmark", "--checkpoint", f"mine={out / 'model'}", "--method", "constant",
                 "--n-frames", "16", "--frame-shape", "64", "192", "--out", str(bench),
                 "--figure-frames", "0", "--quiet"]) == 0
    # Scored on drives of its own training data (the same synthetic streets): marked ‡ (tables.TRAINED_MARK).
    assert re.search(r"\| mine ‡( \(\d+ of \d+ drives\))? \| rect-v1 \|", capsys.readouterr().out)


def test_train_lists_presets_and_rejects_unknown(capsys):
    assert main(["train", "--list"]) == 0
    assert "cpu-1h" in capsys.readouterr().out
    assert main(["train", "--preset", "nope"]) == 1
    assert "unknown preset" in capsys.readouterr().err


def test_staged_preset_warm_starts_the_second_stage(tmp_path):
    import numpy as np

    from estimators.learned.presets import train_preset
    from inpaintenv.data import SyntheticStreets

    ds = SyntheticStreets(n=8, frame_shape=(64, 128))
    est = train_preset("study-cpu", ds, max_steps=2, crop=(32, 64), width=4, depth=2, num_threads=1,
                       checkpoint_dir=tmp_path)
    assert [s["class"] for s in est.stages_] == ["AutoencoderInpainter", "UNetInpainter"]
    assert [s["frames"] for s in est.stages_] == [2, 4]  # 25 % then 50 % of 8 frames
    assert type(est).__name__ == "UNetInpainter" and est.lr == 5e-4
    x = ds[0].copy()
    x[20:40, 30:60] = np.nan
    assert np.isfinite(est.predict(x)).all()


@pytest.fixture
def small_blend_preset(monkeypatch):
    """blend-kitti with one occlusion, 200 pixels, one epoch, no thinned copies: seconds to train."""
    from estimators.learned import presets

    cls, params, desc = presets.PRESETS["blend-kitti"]
    small = {**params, "masks_per_frame": 1, "pixels_per_frame": 200, "epochs": 1, "keep": (1.0,)}
    monkeypatch.setitem(presets.PRESETS, "blend-kitti", (cls, small, desc))


@pytest.fixture
def small_ensemble_preset(monkeypatch):
    """ensemble-kitti with small members (one occlusion, 200 pixels, one epoch, a narrow U-Net): seconds to train."""
    from estimators.learned import presets

    cls, params, desc = presets.PRESETS["ensemble-kitti"]
    from sklearn.base import clone

    members = {name: clone(est) for name, est in params["estimators"]}  # the preset's own stay untouched
    small = {"masks_per_frame": 1, "pixels_per_frame": 200, "epochs": 1, "keep": (1.0,)}
    context = members["context"].set_params(**small, context_widths=(4, 8), n_context=2, batch_frames=2,
                                            batch_pixels=64)
    blend = members["blend"].set_params(**small)
    monkeypatch.setitem(presets.PRESETS, "ensemble-kitti", (cls, {"estimators": [("context", context),
                                                                                 ("blend", blend)]}, desc))


def test_train_ensemble_preset_logs_both_members_and_is_scored(tmp_path, capsys, small_ensemble_preset):
    """ensemble-kitti trains both members into one model folder, logs each member's losses,
    and the benchmark loads it by --checkpoint."""
    out = tmp_path / "run"
    source = ["--n-frames", "6", "--frame-shape", "64", "192"]
    assert main(["train", "--preset", "ensemble-kitti", *source, "--threads", "1", "--out", str(out), "--quiet"]) == 0
    log = json.loads((out / "training_log.json").read_text())
    assert log["estimator"] == "MeanEnsembleInpainter"
    assert {k: len(v) for k, v in log["history"]["epoch_loss_by_member"].items()} == {"context": 1, "blend": 1}
    assert (out / "loss.png").stat().st_size > 0
    config = json.loads((out / "model" / "config.json").read_text())
    assert [m["config"]["params"]["num_threads"] for m in config["members"]] == [1, 1]  # --threads reached both
    assert main(["benchmark", "--checkpoint", f"mine={out / 'model'}", "--method", "constant", *source,
                 "--holdout", "0", "--out", str(tmp_path / "bench"), "--figure-frames", "0", "--quiet"]) == 0
    assert re.search(r"\| mine ‡( \(\d+ of \d+ drives\))? \| rect-v1 \|", capsys.readouterr().out)


def test_default_preset_trains_the_default_release_recipe_and_is_scored(tmp_path, capsys, small_ensemble_preset):
    """With no --preset, train runs ensemble-kitti (the recipe of the default release) and
    the benchmark scores the model by --checkpoint."""
    from inpaintenv.methods.learned import DEFAULT_RELEASE

    out = tmp_path / "run"
    source = ["--n-frames", "6", "--frame-shape", "64", "192"]
    assert main(["train", *source, "--out", str(out), "--quiet"]) == 0
    log = json.loads((out / "training_log.json").read_text())
    assert log["preset"] == "ensemble-kitti" and log["estimator"] == "MeanEnsembleInpainter"
    assert DEFAULT_RELEASE == "kitti-ensemble-v1"
    assert log["environment"]["cpu_count"] >= 1
    assert main(["benchmark", "--checkpoint", f"mine={out / 'model'}", "--method", "constant", *source,
                 "--holdout", "0", "--out", str(tmp_path / "bench"), "--figure-frames", "0", "--quiet"]) == 0
    assert re.search(r"\| mine ‡( \(\d+ of \d+ drives\))? \| rect-v1 \|", capsys.readouterr().out)


def test_set_overrides_a_member_parameter_and_keys_the_run(tmp_path, capsys, small_ensemble_preset):
    """--set member__param=VALUE reaches the ensemble member (JSON values), is recorded with the
    run and keys it: another value starts over and says which --set changed."""
    out = tmp_path / "run"
    source = ["--n-frames", "4", "--frame-shape", "64", "192", "--threads", "1", "--quiet"]
    assert main(["train", "--preset", "ensemble-kitti", *source, "--set", "context__masks_per_frame=2",
                 "--set", "blend__keep=[1.0, 0.5]", "--out", str(out)]) == 0
    config = json.loads((out / "model" / "config.json").read_text())
    members = {m["name"]: m["config"]["params"] for m in config["members"]}
    assert members["context"]["masks_per_frame"] == 2 and members["blend"]["masks_per_frame"] == 1
    assert members["blend"]["keep"] == [1.0, 0.5]
    log = json.loads((out / "training_log.json").read_text())
    assert log["overrides"]["context__masks_per_frame"] == 2
    capsys.readouterr()
    assert main(["train", "--preset", "ensemble-kitti", *source, "--set", "context__masks_per_frame=3",
                 "--set", "blend__keep=[1.0, 0.5]", "--out", str(out)]) == 0
    assert "--set context__masks_per_frame changed (2 -> 3)" in capsys.readouterr().err


def test_train_blend_preset_end_to_end_and_scored_by_checkpoint(tmp_path, capsys, small_blend_preset):
    """The shipped recipe's preset (blend-kitti) trains, saves, and the benchmark loads it
    by --checkpoint; --max-steps, which it has no use for, is a one-line error."""
    out = tmp_path / "run"
    source = ["--n-frames", "6", "--frame-shape", "64", "192"]
    assert main(["train", "--preset", "blend-kitti", *source, "--out", str(out), "--quiet"]) == 0
    log = json.loads((out / "training_log.json").read_text())
    assert log["estimator"] == "BlendInpainter" and len(log["history"]["epoch_loss"]) == 1
    assert main(["benchmark", "--checkpoint", f"mine={out / 'model'}", "--method", "constant", *source,
                 "--holdout", "0", "--out", str(tmp_path / "bench"), "--figure-frames", "0", "--quiet"]) == 0
    # Scored on drives of its own training data (the same synthetic streets): marked ‡ (tables.TRAINED_MARK).
    assert re.search(r"\| mine ‡( \(\d+ of \d+ drives\))? \| rect-v1 \|", capsys.readouterr().out)
    assert main(["train", "--preset", "blend-kitti", "--max-steps", "3", *source, "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert "has no parameter max_steps" in err and "Traceback" not in err


def test_train_jobs_sets_the_blend_feature_workers_and_does_not_restart_the_run(tmp_path, capsys,
                                                                                 small_blend_preset):
    """--jobs only changes how fast the blend's features are computed: the same weights, the
    same run; a preset whose estimator has no n_jobs says so in one line."""
    source = ["--n-frames", "6", "--frame-shape", "64", "192", "--quiet"]
    one, two = tmp_path / "one", tmp_path / "two"
    assert main(["train", "--preset", "blend-kitti", *source, "--jobs", "1", "--out", str(one)]) == 0
    weights_one_job = (one / "model" / "model.safetensors").read_bytes()
    capsys.readouterr()
    assert main(["train", "--preset", "blend-kitti", *source, "--jobs", "2", "--out", str(one)]) == 0
    assert "already finished" in capsys.readouterr().err  # --jobs does not key the run: nothing to redo
    assert main(["train", "--preset", "blend-kitti", *source, "--jobs", "2", "--out", str(two)]) == 0
    log = json.loads((two / "training_log.json").read_text())
    assert log["params"]["n_jobs"] == 2 and log["pixels_per_sample"] == 200
    assert (two / "model" / "model.safetensors").read_bytes() == weights_one_job
    capsys.readouterr()
    assert main(["train", "--preset", "smoke", *source, "--jobs", "2", "--out", str(tmp_path / "u")]) == 1
    err = capsys.readouterr().err
    assert "has no parameter n_jobs" in err and "Traceback" not in err


@pytest.mark.slow
def test_train_scheduler_computes_the_blend_features_on_dask_workers(tmp_path, capsys, small_blend_preset):
    """--scheduler ADDRESS runs the features on the cluster's workers (loopback only here), with
    the same weights as in this process; a step-based preset and a malformed address are
    one-line errors."""
    distributed = pytest.importorskip("distributed")
    source = ["--n-frames", "6", "--frame-shape", "64", "192", "--quiet"]
    here, there = tmp_path / "here", tmp_path / "there"
    assert main(["train", "--preset", "blend-kitti", *source, "--out", str(here)]) == 0
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False, protocol="tcp", host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        before = cluster.scheduler.transition_counter
        assert main(["train", "--preset", "blend-kitti", *source, "--scheduler", cluster.scheduler_address,
                     "--out", str(there)]) == 0
        assert cluster.scheduler.transition_counter - before >= 6  # at least one task per frame ran there
    assert (there / "model" / "model.safetensors").read_bytes() == (here / "model" / "model.safetensors").read_bytes()
    capsys.readouterr()
    assert main(["train", "--preset", "smoke", *source, "--scheduler", "local:2", "--out", str(tmp_path / "u")]) == 1
    err = capsys.readouterr().err
    assert "--scheduler spreads the training features of the blend presets; smoke trains step by step" in err
    assert "Traceback" not in err and not (tmp_path / "u").exists()  # refused before any work
    assert main(["train", "--preset", "blend-kitti", *source, "--scheduler", "nowhere", "--out", str(tmp_path / "v")]) == 1
    assert "--scheduler takes tcp://HOST:PORT or local:N" in capsys.readouterr().err


def test_loss_figure_has_whole_epochs_and_the_loss_unit():
    # loss.png of the blend preset had epochs 1.0, 1.5, 2.0, ... and "training loss" without a unit.
    pytest.importorskip("matplotlib")
    from estimators.learned import BlendInpainter
    from inpaintenv.cli.train import loss_figure

    fig = loss_figure({"epoch_loss": [48.2, 42.9, 42.4]}, "blend", BlendInpainter.loss_label)
    ax = fig.axes[0]
    fig.canvas.draw()
    ticks = [t for t in ax.get_xticks() if ax.get_xlim()[0] <= t <= ax.get_xlim()[1]]
    assert ticks and all(float(t).is_integer() for t in ticks)
    assert ax.get_xlabel() == "epoch" and ax.get_ylabel() == "training loss: mean squared error (m²)"


@pytest.mark.parametrize("argv, message", [
    (["--preset", "blend-kitti", "--max-steps", "10"], "preset 'blend-kitti' (BlendInpainter) has no parameter max_steps"),
    (["--preset", "blend-kitti", "--threads", "0"], "num_threads must be an integer >= 1 or None, got 0"),
    (["--preset", "smoke", "--seed", "-1"], "random_state"),
    (["--preset", "study-cpu", "--jobs", "2"], "preset 'study-cpu' (AutoencoderInpainter) has no parameter n_jobs"),
    (["--preset", "blend-kitti", "--set", "masks_per_frame"], "--set takes KEY=VALUE"),
    (["--preset", "blend-kitti", "--set", "width=8", "--set", "width=16"], "--set width is given twice"),
    (["--preset", "blend-kitti", "--seed", "1", "--set", "random_state=2"], "also as --seed"),
    (["--preset", "blend-kitti", "--set", "epochs=0"], "epochs must be an integer >= 1, got 0"),
    (["--preset", "ensemble-kitti", "--set", "context__nope=1"], "has no nested parameter context__nope"),
    (["--preset", "blend-kitti", "--set", "context__epochs=1"], "has no nested parameter context__epochs"),
])
def test_preset_parameters_are_checked_before_any_file_is_written(tmp_path, capsys, argv, message):
    # `train --preset blend-kitti --max-steps 10` failed only after "starting a new training
    # run" and left train_args.json behind.
    out = tmp_path / "run"
    assert main(["train", *argv, "--n-frames", "2", "--frame-shape", "32", "96", "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert message in err and "starting a new training run" not in err and "Traceback" not in err
    assert not out.exists()


def test_rerunning_a_finished_training_is_a_no_op(tmp_path, capsys, monkeypatch, small_blend_preset):
    # Rerunning a finished blend-kitti training retrained everything ("stopped before its
    # first checkpoint"): a finished run says so and exits 0.
    from estimators.learned import presets

    out = tmp_path / "run"
    argv = ["train", "--preset", "blend-kitti", "--n-frames", "4", "--frame-shape", "64", "192", "--out", str(out),
            "--quiet"]
    assert main(argv) == 0
    log = (out / "training_log.json").read_text()
    assert json.loads((out / "train_args.json").read_text())["finished"] is True
    capsys.readouterr()

    def no_training(*args, **kwargs):
        raise AssertionError("a finished run was trained again")

    monkeypatch.setattr(presets, "train_preset", no_training)
    assert main([*argv, "--threads", "1"]) == 0  # a run-independent override: the same run
    captured = capsys.readouterr()
    assert f"the run in {out} already finished with the same preset, overrides and data" in captured.err
    assert f"model: {out / 'model'}" in captured.out
    assert (out / "training_log.json").read_text() == log
    # Stopped before the end (no "finished"): trained again, and it says why without
    # speaking of checkpoints the blend presets never write.
    (out / "train_args.json").write_text(json.dumps({k: v for k, v in json.loads(
        (out / "train_args.json").read_text()).items() if k != "finished"}))
    monkeypatch.undo()
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert "training again in" in err and "keeps no checkpoints" in err and "first checkpoint" not in err


def test_training_log_records_libraries_threads_and_machine(tmp_path, small_blend_preset):
    import numpy as np
    import torch

    out = tmp_path / "run"
    assert main(["train", "--preset", "blend-kitti", "--n-frames", "4", "--frame-shape", "64", "192",
                 "--threads", "1", "--out", str(out), "--quiet"]) == 0
    log = json.loads((out / "training_log.json").read_text())
    env = log["environment"]
    assert env["versions"]["torch"] == torch.__version__ and env["versions"]["numpy"] == np.__version__
    assert env["torch_threads"] == 1 and env["cpu_count"] >= 1 and env["cpu_model"]
    from inpaintenv.data import SyntheticStreets

    assert log["training_drives"] == sorted(set(SyntheticStreets(n=4, frame_shape=(64, 192)).groups))


SMOKE = ["train", "--preset", "smoke", "--n-frames", "8", "--frame-shape", "64", "192"]


def test_a_second_training_into_the_same_out_is_refused_while_the_first_runs(tmp_path, capsys):
    # Two processes, one folder. The holder stands for a training in progress.
    import subprocess
    import sys
    import textwrap

    out = tmp_path / "run"
    holder = textwrap.dedent("""
        import sys
        from inpaintenv.files.lock import run_lock
        with run_lock(sys.argv[1]):
            print("locked", flush=True)
            sys.stdin.read()
    """)
    proc = subprocess.Popen([sys.executable, "-c", holder, str(out)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            text=True)
    try:
        assert proc.stdout.readline().strip() == "locked"
        assert main([*SMOKE, "--out", str(out), "--quiet"]) == 1
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and f"{out} is in use by another run (pid {proc.pid} on " in err
        assert sorted(p.name for p in out.iterdir()) == ["run.lock"]  # nothing of the run was touched
    finally:
        proc.stdin.close()
        proc.wait(timeout=30)
    assert main([*SMOKE, "--out", str(out), "--quiet"]) == 0  # free once the first has finished


def test_progress_in_a_log_is_plain_lines(tmp_path, capsys):
    # Stderr captured here is not a terminal, like a log file.
    assert main([*SMOKE, "--out", str(tmp_path / "run")]) == 0
    err = capsys.readouterr().err
    assert "\r" not in err
    assert "PriorUNetInpainter" in err  # the bar's last state, as a line of its own


def test_ctrl_c_before_the_first_checkpoint_says_nothing_was_written(tmp_path, capsys, monkeypatch):
    from estimators.learned import presets

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(presets, "train_preset", interrupted)
    assert main([*SMOKE, "--out", str(tmp_path / "run"), "--quiet"]) == 130
    err = capsys.readouterr().err
    assert "no checkpoint was written" in err and "written so far are kept" not in err


def test_stopping_before_max_steps_says_why(tmp_path, capsys):
    assert main([*SMOKE, "--max-steps", "40", "--set", "epochs=1", "--out", str(tmp_path / "run"), "--quiet"]) == 0
    log = json.loads((tmp_path / "run" / "training_log.json").read_text())
    assert log["n_steps"] < 40
    err = capsys.readouterr().err
    assert f"training stopped after {log['n_steps']} of max_steps=40 steps: its 1 epoch ended first" in err


def test_train_input_scan_opens_scans_or_names_the_limitation(tmp_path, capsys, monkeypatch):
    import inpaintenv.cli.train as train_cli

    seen = {}
    monkeypatch.setattr(train_cli, "_train_locked", lambda args, ds, out, record, overrides: seen.update(
        ds=ds, record=record) or 0)
    data = ["--n-frames", "8", "--frame-shape", "64", "192", "--quiet"]
    assert main(["train", "--preset", "blend-kitti", "--input", "scan", "--out", str(tmp_path / "b"), *data]) == 0
    assert seen["ds"].input_kind == "scan" and "input='scan'" in seen["record"]["source"]
    # A density variant trains on the thinned scans.
    assert main(["train", "--preset", "blend-kitti", "--input", "scan-rings8-v1", "--out", str(tmp_path / "r"), *data]) == 0
    assert seen["ds"].input_kind == "scan-rings8-v1" and seen["ds"].input.keep_every == 8
    # A preset whose estimator does not learn from a scan is refused in one line naming it.
    assert main(["train", "--preset", "smoke", "--input", "scan", "--out", str(tmp_path / "s"), *data]) == 1
    err = capsys.readouterr().err.strip()
    assert "--input scan: preset smoke trains a PriorUNetInpainter" in err and "blend-kitti" in err
    assert len(err.splitlines()) == 1 and not (tmp_path / "s").exists()
