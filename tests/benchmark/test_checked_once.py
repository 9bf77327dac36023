"""Validation happens once, where an argument enters: a command's options, or the public
function a user calls; what they call inside takes the checked value as it is.

Counted by wrapping the check at every module that imported it: an interval coverage is
checked exactly once per entry, however many methods, tasks, seeds and batches a run has.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest

import inpaintenv.benchmark.runner
import inpaintenv.cli.benchmark
import inpaintenv.cli.main
import inpaintenv.conventions
import inpaintenv.envs
import inpaintenv.evaluate
import inpaintenv.metrics
import inpaintenv.submission.score
from inpaintenv.benchmark import run_benchmark
from inpaintenv.cli import main
from inpaintenv.data import ArrayDataset
from inpaintenv.envs import DepthInpaintEnv
from inpaintenv.evaluate import evaluate
from inpaintenv.metrics import Coverage, as_coverage, interval_from_std

#: Stand-ins of both ways of giving an interval (its own bounds, or a standard deviation), written
#: as a module the CLI imports by ``module:Class``.
METHODS = '''
import numpy as np


class Bounds:
    def predict(self, x):
        return np.where(np.isnan(x), 10.0, x).astype(np.float32)

    def predict_interval(self, x, coverage=0.9):
        p = self.predict(x)
        return np.maximum(p - 5.0, 0.0), p + 5.0


class Std:
    def predict(self, x, return_std=False):
        p = np.where(np.isnan(x), 10.0, x).astype(np.float32)
        return (p, np.ones_like(p)) if return_std else p
'''


def _count_calls(monkeypatch, module, name: str, within: tuple[str, ...] = ("inpaintenv", "estimators")) -> list:
    """Wrap ``module.name`` with a counter at every loaded module of ``within`` that imported it; the calls' arguments."""
    original = getattr(module, name)
    calls: list = []

    def counting(*args, **kwargs):
        calls.append(args)
        return original(*args, **kwargs)

    for loaded in list(sys.modules.values()):
        if getattr(loaded, "__name__", "").startswith(within) and getattr(loaded, name, None) is original:
            monkeypatch.setattr(loaded, name, counting)
    return calls


@pytest.fixture
def coverage_checks(monkeypatch):
    return _count_calls(monkeypatch, inpaintenv.metrics, "check_coverage")


@pytest.fixture
def methods_module(tmp_path, monkeypatch):
    (tmp_path / "mods").mkdir()
    (tmp_path / "mods" / "twoways.py").write_text(METHODS)
    monkeypatch.syspath_prepend(str(tmp_path / "mods"))
    monkeypatch.delitem(sys.modules, "twoways", raising=False)
    import twoways

    return twoways


@pytest.fixture
def dataset(small_gt):
    return ArrayDataset(np.concatenate([small_gt, small_gt + 1.0]), groups=["d0"] * 3 + ["d1"] * 3)


def test_the_counter_sees_the_modules_that_imported_the_check(coverage_checks):
    inpaintenv.metrics.check_coverage(0.9)
    inpaintenv.cli.benchmark.check_coverage(0.9)
    inpaintenv.metrics._intervals.as_coverage(0.5)  # the check the public functions call
    assert len(coverage_checks) == 3


def test_a_benchmark_command_checks_its_coverage_once(tmp_path, monkeypatch, coverage_checks, methods_module):
    monkeypatch.chdir(tmp_path)
    argv = ["benchmark", "-m", "twoways:Bounds", "-m", "twoways:Std", "--n-frames", "4", "--frame-shape", "64", "96",
            "--holdout", "0", "--seed", "0", "--seed", "1", "--batch-size", "2", "--figure-frames", "0", "--quiet",
            "--out", str(tmp_path / "run"), "--interval-coverage", "0.9"]
    assert main(argv) == 0
    assert [args[1] for args in coverage_checks] == ["--interval-coverage"]
    rows = (tmp_path / "run" / "results.md").read_text()
    assert "hole coverage" in rows  # both methods' intervals were scored


def test_an_evaluate_command_checks_its_coverage_once(tmp_path, coverage_checks, methods_module, capsys):
    argv = ["evaluate", "-m", "twoways:Std", "--n-frames", "4", "--frame-shape", "64", "96", "--seed", "0",
            "--seed", "1", "--batch-size", "2", "--quiet", "--interval-coverage", "0.8"]
    assert main(argv) == 0
    assert [args[1] for args in coverage_checks] == ["--interval-coverage"]


def test_run_benchmark_checks_its_coverage_once(dataset, tmp_path, coverage_checks, methods_module):
    res = run_benchmark({"bounds": methods_module.Bounds(), "std": methods_module.Std()}, dataset,
                        protocols=["rect-v1", "lidar-dropout-v1"], seeds=[0, 1], batch_size=2,
                        out_dir=tmp_path / "run", progress=False, interval_coverage=0.9)
    assert set(res.meta["interval_methods"]) == {"bounds", "std"}
    assert [args[0] for args in coverage_checks] == [0.9]
    assert type(res.meta["interval_coverage"]) is float  # the result holds a plain number


def test_evaluate_checks_its_coverage_once(dataset, coverage_checks, methods_module):
    res = evaluate(methods_module.Std(), dataset, seeds=[0, 1], batch_size=2, intervals=0.9, progress=False)
    assert "hole_coverage" in res.rows[0]
    assert len(coverage_checks) == 1


def test_the_env_checks_its_coverage_once(dataset, coverage_checks):
    env = DepthInpaintEnv(dataset, interval_coverage=0.5)
    for seed in (0, 1):
        obs, _ = env.reset(seed=seed)
        env.step({"depth": np.where(obs["hole"] == 1, 15.0, obs["depth"]).astype(np.float32),
                  "std": np.full_like(obs["depth"], 2.0)})
    assert len(coverage_checks) == 1


def test_run_benchmark_checks_its_seeds_once(dataset, tmp_path, monkeypatch, methods_module):
    # The benchmark's layers (the runner and evaluate): the frames' own loaders are another entry.
    calls = _count_calls(monkeypatch, inpaintenv.conventions, "check_seeds",
                         within=("inpaintenv.benchmark", "inpaintenv.evaluate", "inpaintenv.cli"))
    run_benchmark({"bounds": methods_module.Bounds(), "std": methods_module.Std()}, dataset, seeds=[0, 1],
                  batch_size=2, out_dir=tmp_path / "run", progress=False)
    assert [args[1] for args in calls] == ["seeds"]


def test_a_checked_coverage_is_taken_as_it_is(coverage_checks):
    checked = inpaintenv.metrics.check_coverage(0.9)
    assert isinstance(checked, Coverage) and checked == 0.9
    assert as_coverage(checked) is checked
    interval_from_std(np.full((2, 2), 5.0), np.ones((2, 2)), checked)
    assert len(coverage_checks) == 1
    interval_from_std(np.full((2, 2), 5.0), np.ones((2, 2)), 0.9)  # a plain number is checked where it enters
    assert len(coverage_checks) == 2


@pytest.mark.parametrize("value", [0.0, 1.0, 1.5, -0.1, True, "0.9", float("nan")])
def test_no_coverage_outside_the_open_interval_exists(value):
    with pytest.raises((ValueError, TypeError), match="coverage"):
        Coverage(value)


def _count_folder_checks(monkeypatch) -> tuple[list, list]:
    import inpaintenv.files.lock
    import inpaintenv.files.ownership

    return (_count_calls(monkeypatch, inpaintenv.files.ownership, "check_folder"),
            _count_calls(monkeypatch, inpaintenv.files.lock, "run_lock"))


def test_a_benchmark_command_checks_its_folder_and_takes_its_lock_once(tmp_path, monkeypatch, methods_module):
    monkeypatch.chdir(tmp_path)
    folders, locks = _count_folder_checks(monkeypatch)
    argv = ["benchmark", "-m", "twoways:Bounds", "--n-frames", "4", "--frame-shape", "64", "96", "--holdout", "0",
            "--seed", "0", "--seed", "1", "--batch-size", "2", "--quiet", "--out", str(tmp_path / "run")]
    assert main(argv) == 0
    # Not again in run_benchmark, nor when the run adopts its folder or claims each file it writes.
    assert [args[0] for args in folders] == [tmp_path / "run"]
    assert len(locks) == 1


def test_run_benchmark_checks_its_folder_and_takes_its_lock_once(dataset, tmp_path, monkeypatch, methods_module):
    folders, locks = _count_folder_checks(monkeypatch)
    run_benchmark({"bounds": methods_module.Bounds()}, dataset, protocols=["rect-v1", "lidar-dropout-v1"],
                  seeds=[0, 1], batch_size=2, out_dir=tmp_path / "run", progress=False)
    assert [args[0] for args in folders] == [tmp_path / "run"]
    assert len(locks) == 1
    assert (tmp_path / "run" / "run.json").is_file()


def test_a_benchmark_into_a_file_is_one_line(tmp_path, capsys):
    (tmp_path / "out").write_text("")
    assert main(["benchmark", "-m", "nearest", "--n-frames", "2", "--frame-shape", "64", "96", "--quiet",
                 "--out", str(tmp_path / "out")]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"inpaintenv benchmark: error: --out {tmp_path / 'out'} is a file; the run folder must be a folder"]
