"""Benchmark suites, the resumable runner, reports and figures.

This subpackage (with :mod:`inpaintenv.cli`) is the only part of ``inpaintenv`` that
knows methods by name; it builds them through :mod:`inpaintenv.methods.registry`.
"""

from ..report.stats import bootstrap_mean_ci, bootstrap_ratio_ci
from .headline import CLASSICAL_METHODS, headline_markdown, learned_vs_classical
from ..files.identity import method_identity
from .report import summary_table, to_markdown, write_report
from .runner import RunMismatchError, RunStateError, run_benchmark
from .suites import SUITES, LazyMethod, suite_methods

__all__ = [
    "CLASSICAL_METHODS",
    "headline_markdown",
    "method_identity",
    "learned_vs_classical",
    "SUITES",
    "LazyMethod",
    "RunMismatchError",
    "RunStateError",
    "bootstrap_mean_ci",
    "bootstrap_ratio_ci",
    "run_benchmark",
    "suite_methods",
    "summary_table",
    "to_markdown",
    "write_report",
]
