"""Progress of a benchmark whose stderr is a log file, not a terminal."""

from __future__ import annotations

import re

import pytest

from inpaintenv.benchmark import runner
from inpaintenv.benchmark.suites import SUITES
from inpaintenv.cli import build_parser, main
from inpaintenv.progress import ProgressReporter, format_duration

pytest.importorskip("estimators.classical")

ARGV = ["benchmark", "-m", "scanline", "-m", "constant", "--frame-shape", "32", "96", "--n-frames", "8",
        "--holdout", "0", "--figure-frames", "0", "--batch-size", "2"]


def test_log_gets_plan_estimates_and_periodic_progress(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(runner, "PROGRESS_INTERVAL", 0.0)  # a line at every batch
    assert main([*ARGV, "--out", str(tmp_path)]) == 0
    err = capsys.readouterr().err  # capsys: stderr is not a terminal
    assert ("benchmark: 8 frames × 2 methods × 1 protocol × 1 seed = 16 frame scores; "
            "0 already done, 16 to score") in err
    assert re.search(r"scanline: [\d.]+ s/frame from its first batch, (about \d|under 1 s).* for its 8 frames", err)
    progress = [line for line in err.splitlines() if line.startswith("progress: ")]
    assert progress[-1].startswith("progress: 16/16 frames (100 %)") and "frames/s" in progress[-1]
    assert any(line.startswith("progress: 2/16 frames (12 %)") and "left" in line for line in progress)


def test_resume_estimates_from_the_rows_already_scored(tmp_path, capsys):
    assert main([*ARGV, "--out", str(tmp_path)]) == 0
    for rows in (tmp_path / "rows").glob("*.jsonl"):  # as if killed half-way
        rows.write_text("".join(rows.read_text().splitlines(keepends=True)[:4]))
    capsys.readouterr()
    assert main([*ARGV, "--out", str(tmp_path)]) == 0
    err = capsys.readouterr().err
    assert "8 already done, 8 to score" in err
    assert re.search(r"estimate: (about \d|under 1 s).*\(from the ms/frame of the rows already scored\)", err)


def test_quiet_stays_quiet(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(runner, "PROGRESS_INTERVAL", 0.0)
    assert main([*ARGV, "--out", str(tmp_path), "--quiet"]) == 0
    assert capsys.readouterr().err == ""


def test_help_lists_every_suite_and_its_methods(capsys):
    with pytest.raises(SystemExit):
        build_parser().parse_args(["benchmark", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for name, members in SUITES.items():
        assert f"{name} ({len(members)}): {', '.join(members)}" in text


def test_reporter_sums_time_left_per_method_at_its_own_rate():
    lines: list[str] = []
    now = [0.0]
    rep = ProgressReporter({"slow": 10, "fast": 10}, lines.append, seconds_per_frame={"fast": 0.1},
                           interval=10, clock=lambda: now[0])
    rep.begin("slow")
    now[0] = 4.0
    rep.update(2)  # 2 s/frame measured
    assert lines == ["slow: 2.00 s/frame from its first batch, about 20 s for its 10 frames"]
    now[0] = 12.0
    rep.update(4)  # 6 done in 12 s; left: 4 x 2 s + 10 x 0.1 s
    assert lines[-1] == "progress: 6/20 frames (30 %), 0.5 frames/s, about 9 s left"


def test_format_duration():
    assert [format_duration(s) for s in (4.4, 65, 3725)] == ["4 s", "1 min 05 s", "1 h 02 min"]


def test_wording_of_counts_and_short_durations():
    # "1 frames", "1 drives" and "about 0 s" were printed.
    from inpaintenv.data import SyntheticStreets
    from inpaintenv.progress import ProgressReporter, count, format_duration

    assert (count(1, "frame"), count(0, "frame"), count(2, "drive")) == ("1 frame", "0 frames", "2 drives")
    assert format_duration(0.2) == "under 1 s" and format_duration(0.6) == "1 s"
    lines: list[str] = []
    clock = iter([0.0, 0.0, 0.1]).__next__
    rep = ProgressReporter({"a": 1}, lines.append, interval=10, clock=clock)
    rep.begin("a")
    rep.update(1)
    assert lines == ["a: 0.10 s/frame from its first batch, under 1 s for its 1 frame"]
    assert rep.line(0.1) == "progress: 1/1 frame (100 %), 10.0 frames/s, under 1 s left"
    assert "(1 frame, 1 drive," in repr(SyntheticStreets(n=1, frame_shape=(32, 96)).__getitem__([0]))


def test_frame_progress_outside_a_terminal():
    from inpaintenv.progress import FrameProgress

    lines: list[str] = []
    clock = iter([0.0, 0.0, 0.0, 2.0, 4.0, 12.0, 12.0]).__next__
    with FrameProgress(10, "training features", log=lines.append, interval=10, clock=clock) as progress:
        progress.update(1)  # 2 s
        progress.update(1)  # 4 s
        progress.update(1)  # 12 s: a periodic line is due
    assert lines == [
        "training features: 2.00 s/frame from its first batch, about 20 s for its 10 frames",
        "progress: 3/10 frames (30 %), 0.2 frames/s, about 28 s left",
        "training features: 3 frames in 12 s",
    ]
    silent: list[str] = []
    with FrameProgress(3, "x", enabled=False, log=silent.append) as progress:
        progress.update(3)
    assert silent == []


def test_first_estimate_scales_the_first_methods_rate_by_the_cost_hints():
    """A suite that starts with its slowest method: the time left after that method is the others'
    hinted cost at the measured rate, within 1.5x of what they take (it was their average: 2.4x and more)."""
    from inpaintenv.benchmark.costs import COST_HINTS, relative_costs

    suite = ["pretrained", "harmonic", "scanline", "nearest", "constant", "telea"]
    frames = {m: {"map": 10} for m in suite}
    hints = relative_costs(frames)
    assert set(hints) == set(suite)
    # This machine is 3x slower than the hints' and each method is off its hint by up to 30 %.
    actual = {m: 3e-3 * COST_HINTS[(m, "map")] * f for m, f in zip(suite, (1.0, 1.3, 0.7, 1.3, 0.7, 1.2))}
    now = [0.0]
    rep = ProgressReporter({m: 10 for m in suite}, lambda line: None, relative_cost=hints, clock=lambda: now[0])
    rep.begin("pretrained")
    for _ in range(10):
        now[0] += actual["pretrained"]
        rep.update(1)
    left = sum(10 * actual[m] for m in suite[1:])
    assert left / 1.5 <= rep.estimate() <= left * 1.5
    plain = ProgressReporter({m: 10 for m in suite}, lambda line: None, clock=lambda: now[0])
    plain.spent["pretrained"], plain.done["pretrained"] = rep.spent["pretrained"], 10
    assert plain.estimate() > 1.5 * left  # without hints: every method at the first one's rate


class _SlowFirstCall:
    """A stand-in method whose first call pays a one-time load (``load`` s), each later one ``frame`` s."""

    def __init__(self, load: float = 0.4, frame: float = 0.02) -> None:
        self.load, self.frame, self.calls = load, frame, 0

    def __call__(self, x):
        import time

        import numpy as np

        time.sleep(self.load if self.calls == 0 else self.frame)
        self.calls += 1
        return np.where(np.isnan(x), 10.0, x)


def test_first_estimate_leaves_out_the_one_time_load(tmp_path):
    from inpaintenv.data.synthetic import SyntheticStreets

    lines: list[str] = []
    slow = _SlowFirstCall()
    runner.run_benchmark({"slow": slow, "next": _SlowFirstCall(load=0.02)}, SyntheticStreets(n=4, frame_shape=(24, 64)),
                         out_dir=tmp_path / "run", batch_size=1, log=lines.append)
    assert slow.calls == 5  # the warm-up call, then one per frame
    first = next(line for line in lines if line.startswith("slow: "))
    per_frame = float(re.search(r"([\d.]+) s/frame from its first batch", first).group(1))
    assert per_frame < 0.2, first  # the first call's load (0.4 s) is not a frame's cost
