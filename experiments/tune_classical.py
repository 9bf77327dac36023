"""Compare parameter settings of the classical inpainters on the tuning drive only.

Usage (the command behind the tuning notes in docs/baselines.md)::

    python experiments/tune_classical.py            # every 6th frame of drive 9001

Defaults of the classical estimators were chosen from this output; the other drives
(2011_09_26_drive_9002_sync, val 2011_10_03_drive_9101_sync) were never used for
tuning and are the ones to report on. Scores are hole RMSE / MAE in metres (mean over
frames, rect-v1, seed 0) from :meth:`estimators.BaseInpainter.score_frames`.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from sklearn.model_selection import ParameterGrid

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import TUNING_DRIVE, default_root

from estimators import (
    HarmonicInpainter,
    IPBasicInpainter,
    IterativeBilateralInpainter,
    TeleaInpainter,
)
from inpaintenv.data.kitti import KittiDepth
from inpaintenv.metrics import aggregate

GRIDS = [
    (HarmonicInpainter(), {"iterations": [10, 20, 50, 100]}),
    (IPBasicInpainter(), {"fallback": ["scanline", "nearest", "harmonic"], "extrapolate": [True, False],
                          "large_hole_kernel": [7, 31]}),
    (TeleaInpainter(), {"radius": [3, 5, 9]}),
    (IterativeBilateralInpainter(), {"sigma_color": [2.0, 5.0], "d": [5, 9]}),
]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--root", type=Path, default=default_root())
    parser.add_argument("--every", type=int, default=6)
    args = parser.parse_args(argv)
    ds = KittiDepth(args.root, split="train")
    keep = np.flatnonzero(ds.groups == TUNING_DRIVE)[:: args.every]
    frames = ds.load_batch(keep)
    print(f"{len(keep)} frames of {TUNING_DRIVE}, rect-v1, seed 0\n")
    print("| estimator | hole RMSE | hole MAE |\n|---|---:|---:|")
    for base, grid in GRIDS:
        for params in ParameterGrid(grid):
            est = base.set_params(**params)
            agg = aggregate(est.score_frames(frames))
            print(f"| `{est!r}` | {agg['hole_rmse']:.3f} | {agg['hole_mae']:.3f} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
