"""Fixtures of the benchmark-script tests.

A script of perf/ loaded as a module (the folder is not a package), or one of the
helper modules (``_*.py``) the scripts share.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

import pytest

BENCHMARKS = Path(__file__).resolve().parents[2] / "perf"


@pytest.fixture(scope="session")
def load_benchmark():
    """``load_benchmark("scaling_training")``: ``perf/scaling_training.py`` as a module."""

    def load(name: str) -> ModuleType:
        spec = importlib.util.spec_from_file_location(name, BENCHMARKS / f"{name}.py")
        module = importlib.util.module_from_spec(spec)
        sys.path.insert(0, str(BENCHMARKS))  # a script imports its helper modules, as when run from there
        try:
            spec.loader.exec_module(module)
        finally:
            sys.path.remove(str(BENCHMARKS))
        return module

    return load
