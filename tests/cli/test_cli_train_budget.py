"""``inpaintenv train --max-minutes``: the budget reaches the estimator and stops the run."""

from __future__ import annotations

import json

import pytest

from inpaintenv.cli import main

pytest.importorskip("torch")

SMOKE = ["train", "--preset", "smoke", "--n-frames", "8", "--frame-shape", "64", "192", "--quiet"]


def test_max_minutes_reaches_the_estimator_and_stops_it(tmp_path, capsys, monkeypatch):
    from estimators.learned import _budget

    calls = iter(range(0, 10_000, 60))  # one minute further on at every look
    monkeypatch.setattr(_budget, "clock", lambda: float(next(calls)))
    out = tmp_path / "run"
    assert main([*SMOKE, "--max-steps", "40", "--max-minutes", "1.5", "--out", str(out)]) == 0
    log = json.loads((out / "training_log.json").read_text())
    assert log["overrides"]["max_minutes"] == 1.5
    assert log["n_steps"] == 2
    assert log["history"]["budget_stop"] == {"step": 2, "minutes": 2.0, "max_minutes": 1.5}
    assert "epoch ended first" not in capsys.readouterr().err


def test_max_minutes_is_refused_by_a_preset_without_it(tmp_path, capsys):
    assert main(["train", "--preset", "blend-kitti", "--max-minutes", "1", "--n-frames", "8",
                 "--frame-shape", "64", "192", "--out", str(tmp_path / "run"), "--quiet"]) == 1
    err = capsys.readouterr().err
    assert "has no parameter max_minutes" in err and "Traceback" not in err


def _steps(time_left, durations, monkeypatch):
    """Advance ``time_left`` by one step per duration (seconds) on a fake clock; its texts after each."""
    from estimators.learned import _budget

    now = [0.0]
    monkeypatch.setattr(_budget, "tick", lambda: now[0])
    texts = []
    for d in durations:
        now[0] += d
        time_left.step()
        texts.append(time_left.text())
    return texts


def test_time_left_is_measured_after_the_warm_up_steps(monkeypatch):
    # The first estimate extrapolated a first step that includes the warm-up
    # (2.4x the actual). A slow first step (10 s) and 1 s steps after it, on a fake clock.
    from estimators.learned._budget import WARMUP_STEPS, TimeLeft

    left = TimeLeft(total=100, done=0)
    durations = [10.0] + [1.0] * WARMUP_STEPS
    texts = _steps(left, durations, monkeypatch)
    assert texts[:WARMUP_STEPS] == ["measuring"] * WARMUP_STEPS  # nothing printed from the warm-up
    done = len(durations)
    assert left.seconds() == pytest.approx(1.0 * (100 - done))  # the true time left, not 10 s a step
    assert texts[-1] == f"{(100 - done) // 60}m{(100 - done) % 60:02d}s"


def test_time_left_of_a_resumed_run_counts_only_the_steps_left(monkeypatch):
    from estimators.learned._budget import WARMUP_STEPS, TimeLeft

    left = TimeLeft(total=100, done=90)
    _steps(left, [5.0] * WARMUP_STEPS + [2.0, 2.0], monkeypatch)
    assert left.seconds() == pytest.approx(2.0 * (100 - 90 - WARMUP_STEPS - 2))


def test_time_left_is_capped_by_max_minutes(monkeypatch):
    # A preset with max_steps=1_000_000 and max_minutes=4 stops after 4 minutes, not 1e6 steps.
    from estimators.learned._budget import WARMUP_STEPS, Budget, TimeLeft

    budget = Budget(4.0)
    budget.checked = 1.5  # minutes spent at its last look
    left = TimeLeft(total=1_000_000, done=0, budget=budget)
    _steps(left, [1.0] * (WARMUP_STEPS + 1), monkeypatch)
    assert left.seconds() == pytest.approx(150.0)


def test_the_training_bar_shows_no_extrapolated_remaining_time(tmp_path, capsys):
    # tqdm's own "<remaining" came from the first steps; the bar shows the measured time left instead.
    argv = [a for a in SMOKE if a != "--quiet"]
    assert main([*argv, "--out", str(tmp_path / "run")]) == 0
    bars = [line for line in capsys.readouterr().err.splitlines() if "PriorUNetInpainter:" in line]
    assert bars and all("<" not in line for line in bars)
    # stderr here is a log, not a terminal: one line per epoch, saying the time left is not measured yet.
    assert "time left not measured yet" in bars[-1]
