"""Shared pieces of the submission tests: small synthetic streets and the documented example method."""

from __future__ import annotations

import os
import runpy
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from inpaintenv.data import SyntheticStreets

ROOT = Path(__file__).resolve().parents[2]
#: The example method of docs/submissions.md: a standalone script that needs OpenCV only.
FILL_SCRIPT = ROOT / "docs" / "examples" / "fill_holes.py"


@pytest.fixture(scope="session")
def streets() -> SyntheticStreets:
    """16 small synthetic frames over two drives."""
    return SyntheticStreets(n=16, seed=0, frame_shape=(64, 192))


@pytest.fixture(scope="session")
def fill_script() -> dict:
    """The example script's functions (``predict``, ``main``), loaded without running it."""
    return runpy.run_path(str(FILL_SCRIPT), run_name="fill_holes")


def _run_fill_script(inputs: Path, predictions: Path) -> None:
    """Run the example method as its own process, with nothing of this project importable."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "INPAINTENV_KITTI_ROOT")}
    # -I: isolated mode, no user site and no current folder on sys.path; the blocker makes any
    # import of inpaintenv fail, so the script provably runs on OpenCV alone.
    blocker = "import sys, runpy; sys.modules['inpaintenv'] = None; sys.modules['estimators'] = None; " \
              "sys.argv = sys.argv[1:]; runpy.run_path(sys.argv[0], run_name='__main__')"
    subprocess.run([sys.executable, "-I", "-c", blocker, str(FILL_SCRIPT), str(inputs), str(predictions)],
                   check=True, env=env, cwd=str(predictions.parent), timeout=600)


@pytest.fixture(scope="session")
def run_fill():
    """``run_fill(inputs, predictions)``: the example script as its own process, OpenCV only."""
    return _run_fill_script


@pytest.fixture(scope="session")
def fill_method(fill_script: dict):
    """The example method in this process, as evaluate() calls it: NaN = hole, metres in and out.

    The input is rounded to 1/256 m as the exported PNG stores it, and the output as the
    prediction PNG does, so its scores are those of the files the script writes.
    """
    predict = fill_script["predict"]

    def method(x: np.ndarray) -> np.ndarray:
        raw = np.rint(np.nan_to_num(x, nan=0.0).astype(np.float64) * 256).astype(np.uint16)
        return predict(raw).astype(np.float32) / 256

    return method
