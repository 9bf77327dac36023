"""An interval calibration file: read and written through the safe file layer.

A calibration (``ConformalIntervalInpainter.save``) is data from outside: ``--intervals``
and ``ConformalIntervalInpainter.load`` read files a user was handed. What it may hold
(each field, and what the numbers imply together: a scale far below what its residuals
can have been gives intervals of no width) is :mod:`inpaintenv.values.interval_calibration`'s;
:func:`read_calibration` checks every file with it.

The file is read with :func:`inpaintenv.files.read_json` (regular files only, bounded
size and nesting, no NaN or Infinity) and written with :func:`inpaintenv.files.write_json`
(an exclusive, unpredictably named temporary renamed over the target).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from inpaintenv.exceptions import InvalidInputError
from inpaintenv.files import read_json, write_json
from inpaintenv.values.interval_calibration import (CONDITIONS, DEFAULT_SIGNALS, FORMAT, MAX_ABS_COEF, N_LEVELS,
                                                    SIGNALS, WEIGHTINGS, check_calibration)

__all__ = ["CONDITIONS", "DEFAULT_SIGNALS", "FORMAT", "MAX_ABS_COEF", "MAX_CALIBRATION_BYTES", "N_LEVELS", "SIGNALS", "WEIGHTINGS",
           "check_calibration", "read_calibration", "write_calibration"]

#: Largest calibration file read (a calibration is about 60 kB; the drive lists grow it a little).
MAX_CALIBRATION_BYTES = 4 * 1024 * 1024


def read_calibration(path: str | os.PathLike) -> dict[str, Any]:
    """The checked calibration of the file ``path`` (see :func:`check_calibration`).

    Raises
    ------
    InvalidInputError
        Naming the file: not readable, not a regular file (a FIFO is refused at once), too
        large or too deeply nested, not JSON, a NaN or Infinity, or a field that breaks its rule.
    """
    path = Path(path)
    try:
        doc = read_json(path, "interval calibration", limit=MAX_CALIBRATION_BYTES, allow_nan=False)
    except InvalidInputError:
        raise
    except OSError as exc:
        raise InvalidInputError(f"{path}: not a readable interval calibration ({exc})") from None
    return check_calibration(doc, path)


def write_calibration(path: str | os.PathLike, doc: dict[str, Any]) -> Path:
    """Write ``doc`` to ``path`` whole or not at all, never through a link planted there."""
    return write_json(path, doc)
