"""How much a registry method costs per frame relative to the others, for the run's first time estimate.

The methods of a suite differ in cost by 50x, so the time left cannot be guessed from the
first method's rate alone (the default suite starts with its slowest method, and an estimate
from it alone was 2.4x the run's actual time). :data:`COST_HINTS` holds each method's ms per
KITTI frame (352 x 1216) on each input kind, as the README's KITTI command measured it
(``inpaintenv benchmark --kitti-root <KITTI root> --split val``, the rows' ``ms``, on the
project's shared 2-core VM); only the ratios between methods are used: once a method is
measured on this machine and these frames, the others are estimated at its rate times their
ratio to it (:class:`~inpaintenv.progress.ProgressReporter`'s ``relative_cost``).
"""

from __future__ import annotations

from collections.abc import Mapping

__all__ = ["COST_HINTS", "relative_costs"]

#: ms per KITTI frame by (method, input kind), from the rows of the README's KITTI command.
COST_HINTS: dict[tuple[str, str], float] = {
    ("pretrained", "map"): 1091, ("pretrained", "scan"): 772, ("blend-pretrained-mixed", "map"): 1595,
    ("harmonic", "map"): 284, ("harmonic", "scan"): 314, ("harmonic-inverse", "map"): 330,
    ("ipbasic", "map"): 207, ("ipbasic", "scan"): 212, ("ipbasic-scan", "map"): 274, ("ipbasic-scan", "scan"): 258,
    ("scanline", "map"): 162, ("scanline", "scan"): 127, ("scanline-inverse", "map"): 167,
    ("scanline-2d", "map"): 216, ("nearest", "map"): 45, ("nearest", "scan"): 52, ("telea", "map"): 1779,
    ("ns", "map"): 1999, ("bilateral", "map"): 653, ("constant", "map"): 19, ("telea-hole", "map"): 581,
    ("ns-hole", "map"): 542, ("bilateral-hole", "map"): 750,
}


def relative_costs(frames: Mapping[str, Mapping[str, int]]) -> dict[str, float]:
    """Each method's relative cost per frame of what it has left to score.

    Parameters
    ----------
    frames : mapping
        Method name -> {input kind: frames left to score}.

    Returns
    -------
    dict
        Method name -> its hinted ms per frame, averaged over its frames' input kinds; only
        the methods with a hint for every input kind they score (a checkpoint or a user's
        method has none, and is estimated as before).
    """
    out = {}
    for name, by_kind in frames.items():
        left = {k: n for k, n in by_kind.items() if n}
        if left and all((name, k) in COST_HINTS for k in left):
            out[name] = sum(COST_HINTS[(name, k)] * n for k, n in left.items()) / sum(left.values())
    return out
