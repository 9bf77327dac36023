"""What produced a number: library versions, torch threads and the machine, in one record.

:func:`environment_info` is written beside every benchmark result (``results.json``),
every training run (``training_log.json``) and every saved neural model (its
``config.json``, so a release's JSON says where and with what it was trained). Trained
weights are identical only on the same machine with the same library versions; this
record is what tells two runs apart.

>>> info = environment_info()
>>> sorted(info)                                                   # doctest: +SKIP
['cpu_count', 'cpu_model', 'platform', 'processor', 'python', 'versions']
"""

from __future__ import annotations

import os
import platform
import sys
from functools import lru_cache
from importlib import metadata
from typing import Any

__all__ = ["cpu_model", "environment_info"]

#: Distributions whose versions are recorded (the first installed of each OpenCV flavour).
_DISTRIBUTIONS = ("inpaintenv", "numpy", "scipy", "scikit-learn", "torch", "joblib", "gymnasium")
_OPENCV = ("opencv-python-headless", "opencv-python", "opencv-contrib-python-headless", "opencv-contrib-python")


@lru_cache(maxsize=1)
def cpu_model() -> str:
    """The CPU's model name (``/proc/cpuinfo`` on Linux, else :func:`platform.processor`), or ``"unknown"``."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as f:
            for line in f:
                if line.lower().startswith(("model name", "hardware", "cpu model")):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def _version(dist: str) -> str | None:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return None


def environment_info(*, torch_details: bool | None = None) -> dict[str, Any]:
    """Versions, thread counts and machine facts, for recording beside a result.

    Parameters
    ----------
    torch_details : bool, optional
        Record torch's thread counts, deterministic-algorithms flag and CUDA device.
        Default: only if torch is already imported (the benchmark never imports it itself).

    Returns
    -------
    dict
        ``python``, ``platform``, ``processor`` (architecture), ``cpu_model``,
        ``cpu_count`` (logical cores), ``cpu_affinity`` (cores this process may use,
        where the OS says), ``versions`` (per distribution, None when not installed;
        ``opencv`` is whichever OpenCV wheel is installed), and with torch
        ``torch_threads``, ``torch_interop_threads``, ``torch_deterministic``, ``cuda``
        (and ``cuda_device``).
    """
    versions = {dist: _version(dist) for dist in _DISTRIBUTIONS}
    versions["opencv"] = next((v for v in map(_version, _OPENCV) if v is not None), None)
    info: dict[str, Any] = {
        "python": sys.version.split()[0],
        "platform": platform.platform(),
        "processor": platform.machine(),
        "cpu_model": cpu_model(),
        "cpu_count": os.cpu_count(),
        "versions": versions,
    }
    if hasattr(os, "sched_getaffinity"):
        info["cpu_affinity"] = len(os.sched_getaffinity(0))
    if torch_details is None:
        torch_details = "torch" in sys.modules
    if torch_details:
        import torch

        info["torch_threads"] = torch.get_num_threads()
        info["torch_interop_threads"] = torch.get_num_interop_threads()
        info["torch_deterministic"] = bool(torch.are_deterministic_algorithms_enabled())
        info["cuda"] = bool(torch.cuda.is_available())
        if info["cuda"]:
            info["cuda_device"] = torch.cuda.get_device_name(0)
    return info
