"""What ``gpu_check.py`` reads about the machine, and its first section: the tests marked gpu.

The GPU's dense bf16 peak by name, the ``--max-seconds`` budget, the environment record
(device, torch / CUDA / cuDNN, machine, commit) and ``pytest -m gpu tests/gpu`` in a
subprocess with its counts read from the JUnit XML. Not run by itself.
"""

from __future__ import annotations

import os
import platform
import re
import shutil
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import torch

REPO = Path(__file__).resolve().parents[1]
#: Dense (no sparsity) bf16 tensor-core peaks from NVIDIA's datasheets, TFLOP/s, matched in
#: order as a substring of ``torch.cuda.get_device_name()``.
BF16_PEAK_TFLOPS: tuple[tuple[str, float], ...] = (
    ("H200", 989.0), ("H100 PCIe", 756.0), ("H100 NVL", 835.0), ("H100", 989.0), ("A100", 312.0),
)
#: What each section of a full run needs at least, seconds; below it the section is skipped.
NEEDS = {"tests": 60.0, "train": 20.0, "predict": 10.0}


def bf16_peak_tflops(device_name: str) -> float | None:
    """The dense bf16 peak of a GPU by name (see :data:`BF16_PEAK_TFLOPS`); None if unknown."""
    for key, peak in BF16_PEAK_TFLOPS:
        if re.search(rf"\b{re.escape(key)}\b", device_name):  # not "RTX A1000" for "A100"
            return peak
    return None


class Budget:
    """The ``--max-seconds`` guard: how long is left, and a printed line for what it skips."""

    def __init__(self, max_seconds: float):
        self.max_seconds = float(max_seconds)
        self.start = time.perf_counter()

    def elapsed(self) -> float:
        return time.perf_counter() - self.start

    def left(self) -> float:
        return self.max_seconds - self.elapsed()

    def allows(self, what: str, need: float) -> bool:
        """True if ``need`` seconds are left; else print that ``what`` is skipped."""
        if self.left() >= need:
            return True
        print(f"SKIPPED {what}: {max(self.left(), 0):.0f} s left of --max-seconds {self.max_seconds:g}, "
              f"it needs about {need:.0f} s", flush=True)
        return False


def environment(device: torch.device) -> dict[str, Any]:
    """Device name, torch / CUDA / cuDNN versions and the machine, as printed and in the JSON."""
    cuda = device.type == "cuda"
    env = {
        "device": str(device),
        "device_name": torch.cuda.get_device_name(device) if cuda else f"cpu ({platform.processor() or platform.machine()})",
        "torch": torch.__version__, "cuda": torch.version.cuda or "none",
        "cudnn": torch.backends.cudnn.version() if cuda else None,
        "gpu_memory_bytes": torch.cuda.get_device_properties(device).total_memory if cuda else None,
        "cudnn_allow_tf32": torch.backends.cudnn.allow_tf32, "cudnn_benchmark": torch.backends.cudnn.benchmark,
        "python": platform.python_version(), "cpu_count": os.cpu_count(), "torch_threads": torch.get_num_threads(),
        # The loader's workers hand batches over in shared memory: a small /dev/shm kills them.
        "shm_free_bytes": shutil.disk_usage("/dev/shm").free if os.path.isdir("/dev/shm") else None,
    }
    try:
        env["git_commit"] = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=REPO, capture_output=True,
                                           text=True, timeout=10, check=True).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        env["git_commit"] = None  # the device machine's copy may come without .git
    return env


# -- 1. the tests marked gpu ------------------------------------------------------------
def run_gpu_tests(force_cpu: bool, timeout: float) -> dict[str, Any]:
    """``pytest -m gpu tests/gpu`` in a subprocess; counts read from its JUnit XML."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")]))}
    if force_cpu:
        env["INPAINTENV_GPU_TESTS_ON_CPU"] = "1"
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        xml = Path(tmp) / "gpu.xml"
        cmd = [sys.executable, "-m", "pytest", "-m", "gpu", "tests/gpu", "-q", "-p", "no:cacheprovider",
               f"--junitxml={xml}"]
        try:
            done = subprocess.run(cmd, cwd=REPO, env=env, capture_output=True, text=True, timeout=timeout)
        except subprocess.TimeoutExpired:
            return {"passed": 0, "failed": 0, "errors": 0, "skipped": 0, "failures": [], "returncode": None,
                    "seconds": time.perf_counter() - t0, "error": f"timed out after {timeout:.0f} s"}
        counts = _junit_counts(xml) if xml.is_file() else {"passed": 0, "failed": 0, "errors": 0, "skipped": 0,
                                                            "failures": []}
    counts.update(returncode=done.returncode, seconds=time.perf_counter() - t0, error=None)
    if done.returncode != 0:
        counts["error"] = f"pytest exited {done.returncode}"
        counts["output_tail"] = (done.stdout + done.stderr)[-3000:]
    return counts


def _junit_counts(xml: Path) -> dict[str, Any]:
    cases = ET.parse(xml).getroot().iter("testcase")
    out: dict[str, Any] = {"passed": 0, "failed": 0, "errors": 0, "skipped": 0, "failures": []}
    for case in cases:
        kinds = {child.tag for child in case}
        name = f"{case.get('classname')}::{case.get('name')}"
        if "failure" in kinds:
            out["failed"] += 1
            out["failures"].append(name)
        elif "error" in kinds:
            out["errors"] += 1
            out["failures"].append(name)
        elif "skipped" in kinds:
            out["skipped"] += 1
        else:
            out["passed"] += 1
    return out
