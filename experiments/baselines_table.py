"""Score every classical inpainter on the real KITTI slice and print a Markdown table.

Usage (the command behind docs/baselines.md)::

    python experiments/baselines_table.py                 # train + val, rect-v1, seed 0
    python experiments/baselines_table.py --drives 2011_09_26_drive_9001_sync --every 4
    python experiments/baselines_table.py --methods harmonic scanline-inverse

Frames come from ``--root`` or ``$INPAINTENV_KITTI_ROOT``, cropped to 352×1216 by :class:`inpaintenv.data.kitti.KittiDepth`, and are
scored by :func:`inpaintenv.evaluate.evaluate`. Each method runs with ``n_jobs=1`` so
that ms/frame is single-core time.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from _common import default_root

from estimators import (
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
from inpaintenv.evaluate import EvaluationResult, evaluate

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


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
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


if __name__ == "__main__":
    raise SystemExit(main())
