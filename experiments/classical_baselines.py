"""The classical baselines every release is measured against: their table, and the comparison
their defaults were chosen by.

* ``table``: score every classical inpainter on the real KITTI slice, as a
  Markdown table (formerly ``baselines_table.py``).
* ``tune``: compare parameter settings of the classical inpainters on the
  tuning drive only (formerly ``tune_classical.py``).

``python experiments/classical_baselines.py COMMAND --help`` prints a command's options.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np
from _common import TUNING_DRIVE, default_root, exit_status, run_command
from sklearn.model_selection import ParameterGrid

from estimators.classical import (
    ConstantInpainter,
    HarmonicInpainter,
    IPBasicInpainter,
    IterativeBilateralInpainter,
    NavierStokesInpainter,
    NearestInpainter,
    ScanlineInpainter,
    TeleaInpainter,
)
from inpaintenv.data.base import DepthDataset, Subset
from inpaintenv.data.kitti import KittiDepth
from inpaintenv.evaluate import evaluate
from inpaintenv.report.results import EvaluationResult
from inpaintenv.metrics import aggregate


TABLE_DOC = """Score every classical inpainter on the real KITTI slice and print a Markdown table.

Usage (the command behind docs/baselines.md)::

    python experiments/classical_baselines.py table                 # train + val, rect-v1, seed 0
    python experiments/classical_baselines.py table --drives 2011_09_26_drive_9001_sync --every 4
    python experiments/classical_baselines.py table --methods harmonic scanline-inverse

Frames come from ``--root`` or ``$INPAINTENV_KITTI_ROOT``, cropped to 352×1216 by :class:`inpaintenv.data.kitti.KittiDepth`, and are
scored by :func:`inpaintenv.evaluate.evaluate`. Each method runs with ``n_jobs=1`` so
that ms/frame is single-core time.
"""


#: Every classical method, both fill modes where they exist; name -> estimator.
METHODS = {
    "telea (fill=hole)": TeleaInpainter(fill="hole"),
    "telea": TeleaInpainter(),
    "navier-stokes (fill=hole)": NavierStokesInpainter(fill="hole"),
    "navier-stokes": NavierStokesInpainter(),
    "bilateral (fill=hole)": IterativeBilateralInpainter(fill="hole"),
    "bilateral": IterativeBilateralInpainter(),
    "ip-basic": IPBasicInpainter(),
    "nearest": NearestInpainter(),
    "harmonic": HarmonicInpainter(),
    "harmonic-inverse": HarmonicInpainter(inverse=True),
    "scanline": ScanlineInpainter(),
    "scanline-inverse": ScanlineInpainter(inverse=True),
    "scanline-2d": ScanlineInpainter(vertical=True),
    "scanline-2d-inverse": ScanlineInpainter(inverse=True, vertical=True),
    "constant": ConstantInpainter(),
}

def load_frames(root: Path, splits: list[str], drives: list[str] | None, every: int) -> list[DepthDataset]:
    """One dataset per split (their frame indices seed the masks independently)."""
    out = []
    for split in splits:
        ds = KittiDepth(root, split=split)
        keep = np.arange(len(ds))
        if drives:
            keep = keep[np.isin(ds.groups[keep], drives)]
        keep = keep[::every]
        if len(keep):
            out.append(Subset(ds, keep) if len(keep) < len(ds) else ds)
    if not out:
        raise SystemExit(f"no frames selected under {root} (splits={splits}, drives={drives})")
    return out

def table_command(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="classical_baselines.py table", description=TABLE_DOC.split("\n")[0])
    parser.add_argument("--root", type=Path, default=default_root())
    parser.add_argument("--splits", nargs="+", default=["train", "val"])
    parser.add_argument("--drives", nargs="+", default=None, help="only these drives")
    parser.add_argument("--every", type=int, default=1, help="take every k-th frame")
    parser.add_argument("--methods", nargs="+", default=list(METHODS), choices=list(METHODS))
    parser.add_argument("--protocol", default="rect-v1")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--by-drive", action="store_true", help="also print one table per drive")
    args = parser.parse_args(argv)

    if args.root is None:
        parser.error("needs real KITTI: pass --root <KITTI root> or set INPAINTENV_KITTI_ROOT")
    sources = load_frames(args.root, args.splits, args.drives, args.every)
    results = []
    for name in args.methods:
        for source in sources:
            method = METHODS[name].set_params(n_jobs=1)
            results.append(evaluate(
                method, source, protocol=args.protocol, seeds=(args.seed,), progress=False, name=name,
                # The study's hole-only fills leave 0 m by design and were scored as 0 m.
                unfilled="zero" if method.get_params().get("fill") == "hole" else "error",
            ))
        print(f"done: {name}", file=sys.stderr, flush=True)
    result = EvaluationResult.concat(results)
    n = sum(len(s) for s in sources)
    print(f"{n} frames ({', '.join(args.splits)}), protocol {args.protocol}, seed {args.seed}\n")
    print(result.to_markdown(result.group_table(("method", "protocol"))))
    if args.by_drive:
        print()
        print(result.to_markdown(result.group_table(("method", "protocol", "drive"))))
    return 0


TUNE_DOC = """Compare parameter settings of the classical inpainters on the tuning drive only.

Usage (the command behind the tuning notes in docs/baselines.md)::

    python experiments/classical_baselines.py tune            # every 6th frame of drive 9001

Defaults of the classical estimators were chosen from this output; the other drives
(2011_09_26_drive_9002_sync, val 2011_10_03_drive_9101_sync) were never used for
tuning and are the ones to report on. Scores are hole RMSE / MAE in metres (mean over
frames, rect-v1, seed 0) from :meth:`estimators.BaseInpainter.score_frames`.
"""


GRIDS = [
    (HarmonicInpainter(), {"iterations": [10, 20, 50, 100]}),
    (IPBasicInpainter(), {"fallback": ["scanline", "nearest", "harmonic"], "extrapolate": [True, False],
                          "large_hole_kernel": [7, 31]}),
    (TeleaInpainter(), {"radius": [3, 5, 9]}),
    (IterativeBilateralInpainter(), {"sigma_color": [2.0, 5.0], "d": [5, 9]}),
]

def tune_command(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="classical_baselines.py tune", description=TUNE_DOC.split("\n")[0])
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


COMMANDS = {"table": table_command, "tune": tune_command}


def main(argv: list[str] | None = None) -> Any:
    """Run the command named by ``argv[0]`` (see the module docstring)."""
    return run_command("classical_baselines.py", COMMANDS, argv)


if __name__ == "__main__":
    sys.exit(exit_status(main()))
