"""The ``inpaintenv`` program: its parser, and ``main`` (one line per error, exit statuses).

Each subcommand is one module of :mod:`inpaintenv.cli` with two functions:
``add_<name>(subparsers)`` declares its options and ``cmd_<name>(args)`` runs it;
:data:`SUBCOMMANDS` lists the ``add_`` functions in the order ``--help`` shows them.
Options shared by several subcommands live in :mod:`~inpaintenv.cli.options` (the data
source) and :mod:`~inpaintenv.cli.method_options` (the methods of a run).

Examples
--------
::

    inpaintenv info
    inpaintenv evaluate --method telea --method telea-hole --n-frames 8 --out results/
    inpaintenv show --method ipbasic --index 3 --out panel.png
    inpaintenv report benchmark-results
    inpaintenv info --kitti-root <KITTI root> --split train
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable, Sequence
from typing import Any

from ..exceptions import InpaintenvError
from .benchmark import add_benchmark
from .evaluate import add_evaluate
from .export import add_export
from .fill import add_fill
from .info import add_info
from .messages import print_line
from .report import add_report
from .score import add_score
from .show import add_show
from .train import add_train

__all__ = ["INTERRUPTED", "SUBCOMMANDS", "USER_ERRORS", "build_parser", "is_user_error", "main"]

#: Exit status after Ctrl-C (128 + SIGINT, as shells report it).
INTERRUPTED = 130

#: Errors reported as one line ("inpaintenv: error: ...") with exit status 1, not a traceback:
#: ours (bad input, a missing extra, a lost cluster) and the system's (a missing file, a full
#: disk). Any other exception is a bug and shows its traceback.
USER_ERRORS: tuple[type[BaseException], ...] = (InpaintenvError, OSError)

#: ``add_<name>(subparsers)`` functions, one per subcommand.
SUBCOMMANDS: list[Callable[[Any], None]] = [
    add_info, add_evaluate, add_show, add_benchmark, add_report, add_train, add_export, add_score, add_fill,
]


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every subcommand of :data:`SUBCOMMANDS`."""
    from .._version import __version__

    parser = argparse.ArgumentParser(
        prog="inpaintenv",
        description="Benchmark for depth-only inpainting of large occlusions in outdoor LiDAR depth.",
    )
    parser.add_argument("--version", action="version", version=f"inpaintenv {__version__}")
    subparsers = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for add in SUBCOMMANDS:
        add(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the exit status (0 = success, 1 = error in the inputs,
    130 = interrupted by Ctrl-C).

    Errors in the inputs (:data:`USER_ERRORS`, :func:`is_user_error`), and Ctrl-C, print one
    line to stderr (for Ctrl-C: what was kept and how to resume); set ``INPAINTENV_TRACEBACK=1``
    to get the traceback instead. Any other exception is a bug: it propagates with its traceback.

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments without the program name; ``sys.argv[1:]`` by default.
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    args = build_parser().parse_args(argv)
    args.argv = argv
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        # Ctrl-C: one line saying what is kept and how to continue, not a traceback from
        # wherever the signal landed (often deep inside torch).
        if os.environ.get("INPAINTENV_TRACEBACK"):
            raise
        note = args.on_interrupt(args) if getattr(args, "on_interrupt", None) else "nothing was written"
        print_line(f"inpaintenv {args.command}: interrupted; {note}")
        return INTERRUPTED
    except Exception as exc:
        if os.environ.get("INPAINTENV_TRACEBACK") or not is_user_error(exc):
            raise
        msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        print_line(f"inpaintenv {args.command}: error: {msg}")
        return 1


def is_user_error(exc: BaseException) -> bool:
    """True if ``exc`` is reported as one line: one of :data:`USER_ERRORS`."""
    return isinstance(exc, USER_ERRORS)
