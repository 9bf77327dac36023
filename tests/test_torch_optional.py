"""``pip install inpaintenv`` without the ``[learned]`` extra: everything but the learned
methods works, and naming a learned method is one line saying what to install.

Each check runs in a fresh interpreter whose ``import torch`` and ``import safetensors``
fail (a meta-path finder put first), as on a machine where they were never installed.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
EXTRA = 'pip install "inpaintenv[learned]"'

#: Prepended to every child's code: torch and safetensors cannot be imported.
BLOCKER = textwrap.dedent("""
    import importlib.abc, sys

    class _NoLearnedDeps(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path=None, target=None):
            if name.partition(".")[0] in ("torch", "safetensors"):
                raise ModuleNotFoundError(f"No module named {name!r}", name=name)
            return None

    sys.meta_path.insert(0, _NoLearnedDeps())
""")

#: Small, fast synthetic runs: one drive, every frame scored, no figures.
SYNTHETIC = ["--synthetic", "--n-frames", "2", "--frame-shape", "48", "64", "--holdout", "0", "--figure-frames", "0"]


def _python(code: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "MPLBACKEND": "Agg"}
    env.pop("INPAINTENV_TRACEBACK", None)
    env.pop("INPAINTENV_KITTI_ROOT", None)
    return subprocess.run([sys.executable, "-c", BLOCKER + textwrap.dedent(code)], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)


def _cli(cwd: Path, *argv: str) -> subprocess.CompletedProcess:
    return _python(f"from inpaintenv.cli import main\nsys.exit(main({list(argv)!r}))", cwd)


def test_blocker_hides_torch(tmp_path):
    proc = _python("""
        try:
            import torch
        except ImportError:
            print("blocked")
    """, tmp_path)
    assert proc.stdout.strip() == "blocked", proc.stderr


def test_packages_and_env_work_without_torch(tmp_path):
    proc = _python("""
        import gymnasium as gym
        import numpy as np
        import inpaintenv, estimators, estimators.classical
        from estimators._persistence import as_path  # the checks every save/load makes, the learned one's too
        from estimators.intervals import ConformalIntervalInpainter, release_intervals
        from inpaintenv.methods.registry import make_method

        saved = release_intervals("scanline").save("cal.json", base="scanline")
        assert ConformalIntervalInpainter.load(saved).calibration_ == release_intervals("scanline").calibration_

        env = gym.make("inpaintenv/SyntheticInpaint-v0", n=2, seed=0, frame_shape=(48, 64))
        obs, info = env.reset(seed=0)
        depth = np.where(obs["hole"].astype(bool), np.nan, obs["depth"])
        action = make_method("scanline").predict(depth[None])[0]
        _, reward, terminated, truncated, info = env.step(action.astype(np.float32))
        assert terminated and reward == -info["hole_rmse"]
        assert "torch" not in sys.modules and "safetensors" not in sys.modules
        print("ok")
    """, tmp_path)
    assert proc.returncode == 0 and proc.stdout.strip().endswith("ok"), proc.stderr


def test_classical_method_benchmark_writes_table(tmp_path):
    proc = _cli(tmp_path, "benchmark", *SYNTHETIC, "-m", "scanline", "--out", "run", "-q")
    assert proc.returncode == 0, proc.stderr
    table = (tmp_path / "run" / "results.md").read_text()
    assert "| scanline |" in table


def test_default_suite_scores_classical_and_says_learned_left_out(tmp_path):
    proc = _cli(tmp_path, "benchmark", *SYNTHETIC, "--out", "run", "-q")
    assert proc.returncode == 0, proc.stderr
    table = (tmp_path / "run" / "results.md").read_text()
    assert "| harmonic |" in table and "| telea-hole |" in table
    assert "pretrained" not in table
    notes = [line for line in proc.stderr.splitlines() if "torch" in line.lower()]
    assert len(notes) == 1, proc.stderr
    assert "pretrained" in notes[0] and EXTRA in notes[0]
    assert "Traceback" not in proc.stderr


@pytest.mark.parametrize("argv", [
    ["benchmark", *SYNTHETIC, "--out", "run", "-m", "pretrained"],
    ["benchmark", *SYNTHETIC, "--out", "run", "--suite", "study", "-m", "kitti-mixed-v1"],
    ["evaluate", *SYNTHETIC[:6], "--out", "run", "-m", "blend-pretrained-mixed"],
    ["fill", "frame.npy", "--out", "run", "-m", "pretrained"],
    ["fill", "frame.npy", "--out", "run", "--confidence"],
    ["benchmark", *SYNTHETIC, "--out", "run", "-m", "pretrained-intervals", "--interval-coverage", "0.9"],
    ["train", "--list"],
])
def test_naming_a_learned_method_is_one_line_naming_the_extra(tmp_path, argv):
    proc = _cli(tmp_path, *argv)
    assert proc.returncode == 1, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert EXTRA in lines[0] and "torch" in lines[0]
    assert not (tmp_path / "run" / "results.md").exists()


def test_checkpoint_without_torch_names_the_extra(tmp_path):
    folder = tmp_path / "model"
    folder.mkdir()
    (folder / "model.safetensors").write_bytes(b"")
    (folder / "config.json").write_text("{}")
    proc = _cli(tmp_path, "benchmark", *SYNTHETIC, "--out", "run", "--suite", "study",
                 "--checkpoint", f"mine={folder}")
    assert proc.returncode == 1, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and EXTRA in lines[0], proc.stderr


def test_fill_with_a_classical_method(tmp_path):
    depth = np.zeros((8, 12), np.float32)
    depth[:, :] = 10.0
    depth[2:5, 3:7] = np.nan
    np.save(tmp_path / "frame.npy", depth)
    proc = _cli(tmp_path, "fill", "frame.npy", "--out", "filled", "-m", "scanline", "--format", "npy", "-q")
    assert proc.returncode == 0, proc.stderr
    filled = np.load(next((tmp_path / "filled").rglob("*.npy")))
    assert np.allclose(filled, 10.0)


def test_fill_with_a_classical_methods_shipped_interval(tmp_path):
    depth = np.full((48, 64), 10.0, np.float32)
    depth[10:30, 20:50] = np.nan
    np.save(tmp_path / "frame.npy", depth)
    proc = _cli(tmp_path, "fill", "frame.npy", "--out", "filled", "-m", "scanline", "--confidence", "--format", "npy",
                "-q")
    assert proc.returncode == 0, proc.stderr
    low, high = (np.load(tmp_path / "filled" / f"frame_{s}.npy") for s in ("low", "high"))
    assert (high - low)[10:30, 20:50].min() > 0 and (low <= high).all()


def test_learned_class_from_estimators_names_the_extra(tmp_path):
    proc = _python("""
        import estimators
        try:
            from estimators.learned import UNetInpainter
        except ImportError as exc:
            from inpaintenv.exceptions import MissingDependencyError
            assert isinstance(exc, MissingDependencyError), type(exc)  # one line in the CLI, never a traceback
            print("ImportError:", exc)
    """, tmp_path)
    assert proc.returncode == 0, proc.stderr
    out = proc.stdout.strip()
    assert out.startswith("ImportError:") and "UNetInpainter" in out and EXTRA in out


def _requirement_names(requirements: list[str]) -> set[str]:
    import re

    return {re.split(r"[\s<>=!~\[;]", r, maxsplit=1)[0].lower() for r in requirements}


def test_wheel_does_not_require_torch():
    tomllib = pytest.importorskip("tomllib")  # Python 3.11+
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    required = _requirement_names(project["dependencies"])
    assert not required & {"torch", "safetensors"}
    extras = project["optional-dependencies"]
    assert {"torch", "safetensors"} <= _requirement_names(extras["learned"])
    assert "inpaintenv[learned]" in extras["test"]  # README's `pip install -e ".[test]"` still sets up everything


def test_docs_say_what_each_extra_brings():
    tomllib = pytest.importorskip("tomllib")
    extras = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]) - {"dev"}
    page = (ROOT / "docs" / "estimators.md").read_text()
    assert "| `pip install -e .` |" in page
    assert [e for e in sorted(extras) if f'| `pip install -e ".[{e}]"` |' not in page] == []
    readme = (ROOT / "README.md").read_text()
    assert 'pip install -e ".[learned]"' in readme and "[docs/estimators.md](docs/estimators.md)" in readme
