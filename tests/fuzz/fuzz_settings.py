"""Shared hypothesis settings of the fuzz suite: few examples, no deadline, repeatable.

``derandomize=True`` draws the same examples on every run, so CI never flakes; run with
``--hypothesis-seed=<n>`` and ``FUZZ_EXAMPLES=<n>`` to explore more widely by hand.
"""

from __future__ import annotations

import os

from hypothesis import HealthCheck, settings

#: Multiplier for the examples per property (``FUZZ_EXAMPLES=10`` for a deeper local run).
SCALE = max(1, int(os.environ.get("FUZZ_EXAMPLES", "1")))


def fast(max_examples: int) -> settings:
    """Settings for one property: ``max_examples`` (times ``SCALE``), no deadline, no database."""
    return settings(
        max_examples=max_examples * SCALE,
        deadline=None,
        derandomize=SCALE == 1,
        database=None,
        suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
    )
