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
