"""The wall-clock budget of a training run (``max_minutes``), checked after every step, and
the time left that its progress bar shows.

The time left is measured, not guessed from the first step: the first steps of a run also
start the data loader's workers and warm up the kernels (the first step of a U-Net on the
CPU takes several times a later one), so a rate from them overstates the run. The bar says
``left=measuring`` until :data:`WARMUP_STEPS` steps are done, then divides the time of the
steps since then by their number; a ``max_minutes`` budget caps the estimate.
"""

from __future__ import annotations

import sys
import time
from typing import Any

from tqdm.auto import tqdm

__all__ = ["BAR_FORMAT", "WARMUP_STEPS", "Budget", "StepBar", "TimeLeft", "clock", "record_stop", "tick"]

#: The budget's clock (seconds), looked up at each call: tests replace it.
clock = time.monotonic
#: The clock of the time-left estimate (seconds), looked up at each call: tests replace it.
tick = time.monotonic
#: Steps of a run (in this process) before its time left is estimated: they include warm-up.
WARMUP_STEPS = 3
#: The training bar: tqdm's own ``remaining`` is left out (it extrapolates the first steps);
#: the measured time left is in the postfix (``left=...``).
BAR_FORMAT = "{l_bar}{bar}| {n_fmt}/{total_fmt} [{elapsed}{postfix}]"


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


def _duration(seconds: float) -> str:
    """``seconds`` as ``45s``, ``12m05s`` or ``3h07m``."""
    seconds = int(round(seconds))
    if seconds < 60:
        return f"{seconds}s"
    if seconds < 3600:
        return f"{seconds // 60}m{seconds % 60:02d}s"
    return f"{seconds // 3600}h{seconds % 3600 // 60:02d}m"


class TimeLeft:
    """The time left of a training run, measured on the steps after warm-up.

    Parameters
    ----------
    total : int
        Steps the run takes at most (its bar's total).
    done : int
        Steps already done (a resumed run's checkpoint).
    budget : Budget, optional
        A ``max_minutes`` budget: the run stops when it is spent, so the estimate is at most
        what is left of it.
    warmup : int
        Steps of this process not timed (:data:`WARMUP_STEPS`).
    """

    def __init__(self, total: int, done: int, budget: Budget | None = None, warmup: int = WARMUP_STEPS):
        self.total, self.done, self.budget, self.warmup = total, done, budget, warmup
        self.steps = 0  # steps of this process
        self.since: float | None = None  # tick() when the warm-up ended
        self.timed_from = 0  # steps of this process by then

    def step(self, n: int = 1) -> None:
        """Count ``n`` finished steps."""
        self.steps += n
        self.done += n
        if self.since is None and self.steps >= self.warmup:
            self.since, self.timed_from = tick(), self.steps

    def seconds(self) -> float | None:
        """Seconds left; None until a step after the warm-up has been timed."""
        if self.since is None or self.steps <= self.timed_from:
            return None
        per_step = (tick() - self.since) / (self.steps - self.timed_from)
        left = per_step * max(self.total - self.done, 0)
        if self.budget is not None and self.budget.minutes is not None:
            # As of the budget's last look (after the previous step): no extra look at its clock.
            left = min(left, max(0.0, 60.0 * (self.budget.minutes - self.budget.checked)))
        return left

    def text(self) -> str:
        """``measuring`` during the warm-up, else the time left (``12m05s``)."""
        left = self.seconds()
        return "measuring" if left is None else _duration(left)


class StepBar:
    """The progress bar of training steps (tqdm) with the measured time left (:class:`TimeLeft`)."""

    def __init__(self, total: int, initial: int, budget: Budget | None, *, disable: bool, desc: str):
        self.time_left = TimeLeft(total, initial, budget)
        self.bar = tqdm(total=total, initial=initial, disable=disable, desc=desc, leave=False, bar_format=BAR_FORMAT)

    def update(self, n: int = 1) -> None:
        """``n`` more steps done."""
        self.time_left.step(n)
        self.bar.update(n)

    def set_postfix(self, **values: Any) -> None:
        """Show ``values`` (loss, epoch) and the time left after the bar."""
        self.bar.set_postfix(ordered_dict={**values, "left": self.time_left.text()})

    def close(self) -> None:
        """Close the bar."""
        self.bar.close()
