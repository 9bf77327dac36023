"""Progress lines for runs whose stderr is not a terminal (a log file, CI, ``nohup``).

A terminal gets tqdm bars. A log gets, instead, one line every ``interval`` seconds with
frames done / total, the rate and the time left, and one line per task (e.g. a method)
after its first batch with its own cost, which is the first estimate worth having: the
methods of a suite differ in cost by 50x, so the time left is summed per task, each at
its own measured rate (tasks not started yet at a known rate, or the average so far).

>>> lines = []
>>> clock = iter([0.0, 0.0, 2.0, 20.0]).__next__
>>> rep = ProgressReporter({"a": 4, "b": 4}, lines.append, interval=10, clock=clock)
>>> rep.begin("a"); rep.update(2); rep.update(2)
>>> lines[0]
'a: 1.00 s/frame from its first batch, about 4 s for its 4 frames'
>>> lines[1]
'progress: 4/8 frames (50 %), 0.2 frames/s, about 20 s left'
"""

from __future__ import annotations

import re
import sys
import time
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["FrameProgress", "PlainLines", "ProgressReporter", "count", "format_duration", "stderr_is_terminal"]


def count(n: int, word: str, plural: str | None = None) -> str:
    """``"1 frame"``, ``"3 frames"``: a number and its noun, singular when it is 1."""
    return f"{n} {word if n == 1 else (plural or word + 's')}"


def stderr_is_terminal() -> bool:
    """True when stderr is an interactive terminal (tqdm bars), False for a file or pipe."""
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):  # replaced or closed stream
        return False


def format_duration(seconds: float) -> str:
    """``"under 1 s"``, ``"45 s"``, ``"3 min 05 s"``, ``"2 h 07 min"``."""
    s = max(0, round(seconds))
    if s < 1:
        return "under 1 s"
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60:02d} s"
    return f"{s // 3600} h {(s % 3600) // 60:02d} min"


def _about(seconds: float) -> str:
    """``"about 3 min 05 s"``, or ``"under 1 s"`` (never "about 0 s")."""
    text = format_duration(seconds)
    return text if text.startswith("under") else f"about {text}"


class ProgressReporter:
    """Counts scored frames per task and writes progress lines to ``log``.

    Parameters
    ----------
    todo : mapping of str to int
        Frames to score per task (e.g. per method), in the order they run.
    log : callable
        Receives each line.
    seconds_per_frame : mapping of str to float, optional
        Known cost of some tasks (e.g. from rows scored by an earlier run).
    relative_cost : mapping of str to float, optional
        A hint of some tasks' cost relative to each other (any unit): a task not measured yet
        is estimated at the measured tasks' cost scaled by these ratios, instead of at their
        average (tasks differ in cost by 50x).
    interval : float
        Seconds between periodic lines.
    clock : callable
        Monotonic clock (seconds); replaceable in tests.
    """

    def __init__(
        self,
        todo: Mapping[str, int],
        log: Callable[[str], None],
        *,
        seconds_per_frame: Mapping[str, float] | None = None,
        relative_cost: Mapping[str, float] | None = None,
        interval: float = 10.0,
        clock: Callable[[], float] = time.monotonic,
    ):
        self.todo = {k: int(v) for k, v in todo.items()}
        self.total = sum(self.todo.values())
        self.log = log
        self.known = dict(seconds_per_frame or {})
        self.relative = {k: float(v) for k, v in (relative_cost or {}).items() if v > 0}
        self.interval = float(interval)
        self.clock = clock
        self.done: dict[str, int] = {k: 0 for k in self.todo}
        self.spent: dict[str, float] = {k: 0.0 for k in self.todo}
        self.current: str | None = None
        self._mark = self._last_line = clock()

    def estimate(self) -> float | None:
        """Seconds left, or None while nothing is measured or known."""
        measured = {k: self.spent[k] / self.done[k] for k in self.todo if self.done[k]}
        rates = {**self.known, **measured}
        if not rates:
            return None
        average = sum(self.spent.values()) / max(1, sum(self.done.values())) if measured else (
            sum(rates.values()) / len(rates)
        )
        # Seconds per unit of hinted cost, from the tasks both measured (or known) and hinted.
        hinted = [k for k in rates if k in self.relative]
        scale = sum(rates[k] for k in hinted) / sum(self.relative[k] for k in hinted) if hinted else None
        guess = {k: self.relative[k] * scale for k in self.relative if k not in rates} if scale else {}
        return sum((self.todo[k] - self.done[k]) * rates.get(k, guess.get(k, average)) for k in self.todo)

    def drop(self, task: str) -> None:
        """Leave ``task`` out (e.g. a method not available here): its frames are not to do."""
        self.total -= self.todo[task] - self.done[task]
        self.todo[task] = self.done[task]

    def begin(self, task: str) -> None:
        """Start timing ``task`` (a key of ``todo``)."""
        self.current = task
        self._mark = self.clock()

    def warmed(self) -> None:
        """The current task's one-time start (its warm-up call, a model's first load) is over: the time
        since :meth:`begin` is left out of its per-frame cost."""
        if self.current is not None and self.done[self.current] == 0:
            self._mark = self.clock()

    def update(self, n: int) -> None:
        """Count ``n`` more frames of the current task; log a line when one is due."""
        if self.current is None:
            raise RuntimeError("ProgressReporter.update before begin")
        now = self.clock()
        task = self.current
        first = self.done[task] == 0
        self.spent[task] += now - self._mark
        self.done[task] += n
        self._mark = now
        if first and self.todo[task]:
            spf = self.spent[task] / self.done[task]
            left = format_duration(spf * self.todo[task])
            self.log(f"{task}: {spf:.2f} s/frame from its first batch, {'' if left.startswith('under') else 'about '}"
                     f"{left} for its {count(self.todo[task], 'frame')}")
        if now - self._last_line >= self.interval:
            self._last_line = now
            self.log(self.line(now))

    def line(self, now: float | None = None) -> str:
        """``progress: done/total frames (pct), rate, time left``."""
        done = sum(self.done.values())
        elapsed = sum(self.spent.values())
        rate = f"{done / elapsed:.1f} frames/s" if elapsed > 0 else "rate unknown"
        left = self.estimate()
        when = "time left unknown" if left is None else _about(left) + " left"
        pct = 100 * done / self.total if self.total else 100.0
        return f"progress: {done}/{count(self.total, 'frame')} ({pct:.0f} %), {rate}, {when}"


class FrameProgress:
    """One progress display for a loop over frames, on a terminal and in a log alike.

    A terminal gets a tqdm bar (frames done of total, rate, time left); anything else
    (a log file, CI) gets the lines of :class:`ProgressReporter` (the cost from the first
    frame, then every ``interval`` seconds frames done / total, rate and time left) and
    one closing line with the total time. Use as a context manager; call :meth:`update`
    once per frame done.

    Parameters
    ----------
    total : int
        Frames to do.
    desc : str
        What the frames are for, e.g. ``"training features"``.
    enabled : bool
        False: show nothing.
    log : callable, optional
        Receives the lines outside a terminal (default: print to stderr).
    interval : float
        Seconds between periodic lines outside a terminal.
    clock : callable
        Monotonic clock (seconds); replaceable in tests.
    """

    def __init__(self, total: int, desc: str, *, enabled: bool = True, log: Callable[[str], None] | None = None,
                 interval: float = 10.0, clock: Callable[[], float] = time.monotonic):
        self.total, self.desc, self.clock = int(total), desc, clock
        self.log = log or (lambda line: print(line, file=sys.stderr, flush=True))
        self._bar = self._reporter = None
        self._start = clock()
        if not enabled or self.total <= 0:
            return
        if log is None and stderr_is_terminal():
            from tqdm.auto import tqdm

            self._bar = tqdm(total=self.total, desc=desc, unit="frame", leave=False)
        else:
            self._reporter = ProgressReporter({desc: self.total}, self.log, interval=interval, clock=clock)
            self._reporter.begin(desc)

    def update(self, n: int = 1) -> None:
        """Count ``n`` more frames done."""
        if self._bar is not None:
            self._bar.update(n)
        elif self._reporter is not None:
            self._reporter.update(n)

    def close(self) -> None:
        """End the display (outside a terminal: one line with the frames and the time taken)."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None
        elif self._reporter is not None:
            done = sum(self._reporter.done.values())
            self.log(f"{self.desc}: {count(done, 'frame')} in {format_duration(self.clock() - self._start)}")
            self._reporter = None

    def __enter__(self) -> FrameProgress:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class PlainLines:
    """A text stream for a log file that turns progress-bar redraws into plain lines.

    A tqdm bar redraws itself after a carriage return (``\\r``); in a log file that is one
    endless line. Written through this stream, ordinary lines pass unchanged, and the
    latest state of a bar becomes a line of its own at most every ``interval`` seconds,
    and once more when the stream is closed (so the log ends with the last state).

    Parameters
    ----------
    stream : text stream
        Where the lines go (e.g. the real ``sys.stderr``).
    interval : float
        Seconds between two lines of a bar.
    clock : callable
        Monotonic clock (seconds); replaceable in tests.

    Examples
    --------
    >>> import io
    >>> sink = io.StringIO()
    >>> lines = PlainLines(sink, interval=10.0, clock=iter([0.0, 1.0, 2.0]).__next__)
    >>> _ = lines.write("start\\n\\rstep 1/3\\rstep 2/3\\rstep 3/3")
    >>> lines.close()
    >>> sink.getvalue().splitlines()
    ['start', 'step 1/3', 'step 3/3']
    """

    def __init__(self, stream: Any, interval: float = 10.0, clock: Callable[[], float] = time.monotonic):
        self.stream, self.interval, self.clock = stream, float(interval), clock
        self._current = ""  # text after the last \r or \n, not yet ended
        self._last_shown: float | None = None
        self._pending = ""  # the bar's latest state, not yet written as a line

    def write(self, text: str) -> int:
        """Write ``text``: complete lines at once, bar states as lines every ``interval`` s."""
        for part in re.split(r"(\r|\n)", text):
            if part == "\n":
                self._end_line()
            elif part == "\r":
                self._bar_state(self._current)
                self._current = ""
            else:
                self._current += part
        return len(text)

    def _end_line(self) -> None:
        if self._current.strip():
            self._flush_pending()
            self.stream.write(self._current.rstrip() + "\n")
        self._current = ""

    def _bar_state(self, state: str) -> None:
        if not state.strip():
            return
        self._pending = state.strip()
        now = self.clock()
        if self._last_shown is None or now - self._last_shown >= self.interval:
            self._flush_pending()
            self._last_shown = now

    def _flush_pending(self) -> None:
        if self._pending:
            self.stream.write(self._pending + "\n")
            self._pending = ""

    def flush(self) -> None:
        """Flush the underlying stream (a bar's pending state waits for its next line)."""
        self.stream.flush()

    def close(self) -> None:
        """Write the bar's last state, if not written yet, and flush."""
        self._bar_state(self._current)
        self._current = ""
        self._flush_pending()
        self.stream.flush()

    def isatty(self) -> bool:
        """Never a terminal: progress displays write log lines to it."""
        return False
