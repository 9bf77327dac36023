"""The learned-vs-classical headline of benchmark run folders, pooled over their drives.

``inpaintenv benchmark`` prints the headline per drive; a fold that leaves out a whole
recording day (``experiments/lodo_days.sh``) is judged on all of that day's frames at
once: the strongest classical method is the one with the lowest mean hole RMSE over the
fold's frame-masks, and the ratio's paired 95 % interval resamples them
(:func:`inpaintenv.benchmark.headline.learned_vs_classical` with ``keys=("protocol",)``).

Examples
--------
    python experiments/pooled_headline.py lodo-days/bench-day-2011_09_30 lodo-days/bench-drive-0001
    python experiments/pooled_headline.py lodo-days/bench-day-2011_09_30 --learned kitti-rect-v4

``--learned NAME`` compares that learned method alone (the run's other learned methods
left out) instead of the best learned method of the run.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from inpaintenv.benchmark.headline import (
    CLASSICAL_METHODS,
    headline_markdown,
    learned_vs_classical,
)
from inpaintenv.report.results import EvaluationResult


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("runs", nargs="+", help="benchmark run folders (each holding results.json)")
    p.add_argument("--learned", metavar="NAME", help="compare this learned method alone")
    args = p.parse_args(argv)
    for run in args.runs:
        path = Path(run) / "results.json"
        if not path.is_file():
            print(f"{path}: no such file (run the benchmark first)", file=sys.stderr)
            return 1
        result = EvaluationResult.from_json(path)
        if args.learned:
            if args.learned not in {r["method"] for r in result.rows}:
                print(f"{path}: no rows of {args.learned!r}", file=sys.stderr)
                return 1
            keep = set(CLASSICAL_METHODS) | {args.learned}
            result = EvaluationResult(rows=[r for r in result.rows if r["method"] in keep], meta=result.meta)
        drives = sorted({str(r["drive"]) for r in result.rows})
        print(f"## {run} ({len(drives)} drive{'s' if len(drives) != 1 else ''} pooled)\n")
        print(headline_markdown(learned_vs_classical(result, keys=("protocol",)), keys=("protocol",)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
