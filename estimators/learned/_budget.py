"""The wall-clock budget of a training run (``max_minutes``), checked after every step."""

from __future__ import annotations

import sys
import time
from typing import Any

from tqdm.auto import tqdm

__all__ = ["Budget", "clock", "record_stop"]

#: The budget's clock (seconds), looked up at each call: tests replace it.
clock = time.monotonic


class Budget:
    """``minutes`` from the start of one call of the training loop (None: no limit).

    Only this process's own time counts: a run resumed from a checkpoint gets its whole
    budget again, whatever the earlier run spent.
    """

    def __init__(self, minutes: float | None):
        self.minutes = minutes
        self.start = clock()
        #: Minutes elapsed at the last :meth:`spent` check.
        self.checked = 0.0

    def elapsed(self) -> float:
        """Minutes since the start."""
        return (clock() - self.start) / 60.0

    def spent(self) -> bool:
        """Whether the budget has run out (never, without one)."""
        if self.minutes is None:
            return False
        self.checked = self.elapsed()
        return self.checked >= self.minutes


def record_stop(progress: dict[str, Any], budget: Budget, name: str, say: bool) -> None:
    """Record in ``progress``'s history that the budget stopped the run; one line if ``say``."""
    minutes = budget.checked
    progress["history"]["budget_stop"] = {"step": progress["step"], "minutes": minutes, "max_minutes": budget.minutes}
    if say:
        tqdm.write(f"{name}: stopped on max_minutes={budget.minutes:g} after step {progress['step']} "
                   f"({minutes:.2f} min); fit again with the same parameters to resume", file=sys.stderr)
