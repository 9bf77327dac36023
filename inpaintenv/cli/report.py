"""``inpaintenv report``: rebuild ``report.html`` of a benchmark run folder from what the run wrote there."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from ..exceptions import InvalidInputError

__all__ = ["add_report", "cmd_report"]


def add_report(subparsers: Any) -> None:
    """Declare ``inpaintenv report``."""
    p = subparsers.add_parser(
        "report", help="rebuild report.html of a benchmark run folder",
        description=(
            "Rebuild RUN_FOLDER/report.html from the run's rows, run.json, results.json and figure files: "
            "the results table, the figures of every task and the run's provenance, in one page that opens "
            "offline. Nothing is scored or predicted again."
        ),
    )
    p.add_argument("run_folder", metavar="RUN_FOLDER", help="folder of a benchmark, evaluate --out or score run")
    p.add_argument("--quiet", "-q", action="store_true", help="print nothing but errors")
    p.set_defaults(func=cmd_report)


def cmd_report(args: argparse.Namespace) -> int:
    """Run ``inpaintenv report``: check the folder is a run's, hold its lock, write the page."""
    from ..benchmark.html import write_html_report
    from ..files.lock import run_lock
    from ..files.ownership import adopt, check_folder

    out = Path(args.run_folder)
    if not out.is_dir():
        raise InvalidInputError(f"{out} is not a folder; give the folder of a benchmark run")
    if not (out / "rows").is_dir() or (out / "rows").is_symlink():
        raise InvalidInputError(f"{out} holds no rows of a benchmark run (rows/*.jsonl); nothing to report")
    log = (lambda msg: None) if args.quiet else (lambda msg: print(msg, file=sys.stderr))
    check_folder(out)  # a folder no run wrote is refused before anything is written in it
    with run_lock(out, log):  # not while a run writes its rows there
        adopt(out)
        path = write_html_report(out, log)
    if path is None:
        raise InvalidInputError(f"{out} holds no rows of a benchmark run (rows/*.jsonl); nothing to report")
    print(path)
    return 0
