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
left out) instead of the best learned method of the run. ``--gate-ceiling`` adds what a
per-frame fall-back gate could reach at best: each frame-mask scored by whichever of the
learned method and the run's classical methods did best on it, with hindsight, over the
strongest classical method's mean, and the share of frame-masks on which the learned method
is worse than the best classical one.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from inpaintenv.benchmark.headline import (
    CLASSICAL_METHODS,
    headline_markdown,
    learned_vs_classical,
)
from inpaintenv.report.results import EvaluationResult


def gate_ceiling(result: EvaluationResult, learned: str, classical: str) -> dict[str, float]:
    """Hindsight per-frame choice between ``learned`` and every classical method of ``result``.

    Returns the mean over frame-masks (hole with ground truth, scored by every one of those
    methods) of the lowest hole RMSE, divided by ``classical``'s mean on the same frame-masks,
    and the share of frame-masks where ``learned`` is worse than the best classical method.
    """
    methods = {learned} | {r["method"] for r in result.rows if r["method"] in CLASSICAL_METHODS}
    if len(methods) < 2:
        raise ValueError("no classical method in the run to fall back to")
    table: dict[tuple, dict[str, float]] = {}
    for r in result.rows:
        if r["method"] in methods and r["hole_count"] > 0:
            table.setdefault((r["protocol"], r["seed"], r["frame_id"]), {})[r["method"]] = r["hole_rmse"]
    full = [v for v in table.values() if len(v) == len(methods)]
    if not full:
        raise ValueError(f"no frame-mask is scored by {learned} and every classical method of the run")
    best = np.array([min(v.values()) for v in full])
    best_classical = np.array([min(x for m, x in v.items() if m != learned) for v in full])
    return {"ceiling": float(best.mean() / np.mean([v[classical] for v in full])),
            "learned_worse": float(np.mean([v[learned] > b for v, b in zip(full, best_classical)])),
            "n": len(full)}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("runs", nargs="+", help="benchmark run folders (each holding results.json)")
    p.add_argument("--learned", metavar="NAME", help="compare this learned method alone")
    p.add_argument("--gate-ceiling", action="store_true",
                   help="also print the hindsight per-frame choice between the learned and the classical methods")
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
        entries = learned_vs_classical(result, keys=("protocol",))
        print(headline_markdown(entries, keys=("protocol",)))
        if args.gate_ceiling:
            for e in entries:
                proto = EvaluationResult(rows=[r for r in result.rows if r["protocol"] == e["protocol"]])
                g = gate_ceiling(proto, e["learned"], e["classical"])
                print(f"\n{e['protocol']}: a per-frame gate with hindsight between {e['learned']} and the classical "
                      f"methods reaches {g['ceiling']:.3f}x {e['classical']}; {e['learned']} is worse than the best "
                      f"classical method on {100 * g['learned_worse']:.0f} % of {g['n']} frame-masks")
    return 0


if __name__ == "__main__":
    sys.exit(main())
