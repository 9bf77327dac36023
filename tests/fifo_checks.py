"""A call that must not wait on a FIFO: shared by the tests of every reader that refuses one."""

from __future__ import annotations

import os
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any


def returns_within(seconds: float, call: Callable[[], Any], fifo: Path) -> BaseException | None:
    """What ``call()`` raised (None if nothing), asserting it returned within ``seconds``.

    A reader still waiting on ``fifo`` is then released by opening it for writing, so a
    hang fails the test instead of blocking the suite.
    """
    outcome: list[BaseException | None] = []

    def run() -> None:
        try:
            call()
            outcome.append(None)
        except BaseException as exc:  # noqa: BLE001 - handed to the test
            outcome.append(exc)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    thread.join(seconds)
    if thread.is_alive():
        os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))
    assert outcome, f"still waiting on {Path(fifo).name} after {seconds} s"
    return outcome[0]
