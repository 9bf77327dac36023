"""Which process wrote a temporary name, and whether it still runs: one parser, one liveness check.

Temporary files and folders of the package carry their writer's process id
(``.inpaintenv-tmp-<pid>-...``, ``.<out>.partial-<pid>-...``), and a lock file its
holder's, so that what a killed run left can be cleared. A name is data from the folder,
not ours until it parses: a pid is 1 to 10 ASCII digits (``"²"`` is a digit to
``str.isdigit``, a 23-digit number overflows ``os.kill``) no larger than :data:`MAX_PID`;
anything else is left alone.
"""

from __future__ import annotations

import os
import re

__all__ = ["MAX_PID", "parse_pid", "pid_alive", "writer_gone"]

#: The largest process id a name may carry (a C ``pid_t``; Linux's own limit is 2**22).
MAX_PID = 2**31 - 1
_PID = re.compile(r"[0-9]{1,10}", re.ASCII)


def parse_pid(text: object) -> int | None:
    """The process id ``text`` writes (ASCII digits, 1 .. :data:`MAX_PID`), else None.

    An ``int`` (a lock file's JSON) is taken as it is when in range; a ``bool`` is not a pid.
    """
    if isinstance(text, bool):
        return None
    if isinstance(text, int):
        return text if 1 <= text <= MAX_PID else None
    if not isinstance(text, str) or _PID.fullmatch(text) is None:
        return None
    pid = int(text)
    return pid if 1 <= pid <= MAX_PID else None


def pid_alive(pid: int) -> bool:
    """Whether process ``pid`` (a parsed one) runs; where this cannot be asked, it is taken to run."""
    if os.name != "posix":
        return True  # os.kill would end the process there, not probe it
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (OSError, OverflowError):  # another user's process (EPERM), or not askable: leave its files
        return True
    return True


def writer_gone(text: object) -> bool:
    """Whether ``text`` names a process (see :func:`parse_pid`) other than this one that no longer runs.

    False for anything that does not parse: a name the package did not write is left alone.
    """
    pid = parse_pid(text)
    return pid is not None and pid != os.getpid() and not pid_alive(pid)
