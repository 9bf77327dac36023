"""Where the hole error comes from: squared error by true depth, per method, on the selection frames.

Hole RMSE in metres is dominated by the few far pixels inside a hole; this prints,
per true-depth bin, the share of hole pixels, the share of summed squared error, the
RMSE and the bias (mean prediction − truth) of each method, pooled over the selection
frames of ``experiments/pretrained_selection.py`` (drive 9001 frames 56-67, seed 0), or
over every frame of the ``--drive`` drives under the ``--seed`` seeds (e.g. where a
leave-one-day-out fold model loses; score models on drives they were not trained on).

Examples
--------
    python experiments/error_anatomy.py --kitti-root <KITTI root> kitti-rect-v3 -m harmonic-inverse
    python experiments/error_anatomy.py --kitti-root <KITTI root> --drive 2011_10_03_drive_9042_sync \\
        --seed 0 --seed 1 lodo/train-day-2011_10_03-context-kitti-draws/model -m scanline
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from inpaintenv.data.kitti import KittiDepth
from inpaintenv.masks import get_protocol
from inpaintenv.metrics import depth_binned_errors
from pretrained_selection import DRIVE, N_TRAIN
from selection_scores import batch_predictor

#: |error| above which a pixel counts as a gross error (metres).
GROSS_ERROR = 10.0


def anatomy(pred: np.ndarray, gt: np.ndarray, holes: np.ndarray) -> dict:
    """Binned errors plus the share of squared error from gross errors (> ``GROSS_ERROR`` m)."""
    scored = holes & (gt > 0)
    err = pred[scored].astype(np.float64) - gt[scored]
    gross = np.abs(err) > GROSS_ERROR
    return {
        "bins": depth_binned_errors(pred, gt, holes),
        "gross_pixel_share": float(gross.mean()),
        "gross_sse_share": float((err[gross] ** 2).sum() / max((err**2).sum(), 1e-12)),
        "pooled_hole_rmse": float(np.sqrt((err**2).mean())),
    }


def main(argv: list[str] | None = None) -> list[dict]:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("models", nargs="*", help="shipped model names or saved model directories")
    p.add_argument("-m", "--method", action="append", default=[], help="registry method (repeatable)")
    p.add_argument("--kitti-root", required=True)
    p.add_argument("--protocol", default="rect-v1")
    p.add_argument("--drive", action="append",
                   help="every frame of this train drive instead of the selection frames (repeatable)")
    p.add_argument("--camera", default="image_02", help="camera of --drive's frames (image_02, image_03, both)")
    p.add_argument("--seed", type=int, action="append", help="mask seed (repeatable; default 0)")
    args = p.parse_intermixed_args(argv)
    if args.drive:  # frame i of the drives gets the mask of position i, as in a benchmark of those drives
        frames = KittiDepth(args.kitti_root, split="train", drives=args.drive, camera=args.camera)
        sel = frames.load_batch(range(len(frames)))
    else:
        frames = KittiDepth(args.kitti_root, split="train", drives=[DRIVE])
        sel = frames.load_batch(range(N_TRAIN, len(frames)))
    protocol = get_protocol(args.protocol)
    seeds = args.seed or [0]
    holes = np.concatenate([protocol.masks(sel.shape[1:], s, range(len(sel))) for s in seeds])
    sel = np.concatenate([sel] * len(seeds))
    corrupted = np.where(holes, np.nan, sel).astype(np.float32)
    rows = []
    for label, kind in [(m, "model") for m in args.models] + [(m, "method") for m in args.method]:
        row = {"name": label, "protocol": args.protocol, **anatomy(batch_predictor(label, kind)(corrupted), sel, holes)}
        print(f"\n{label} ({args.protocol}): pooled hole RMSE {row['pooled_hole_rmse']:.2f} m; "
              f"|error| > {GROSS_ERROR:g} m on {100 * row['gross_pixel_share']:.1f} % of pixels "
              f"= {100 * row['gross_sse_share']:.0f} % of the squared error")
        print("| true depth (m) | pixels % | squared error % | RMSE (m) | bias (m) |\n|---|---:|---:|---:|---:|")
        for b in row["bins"]:
            print(f"| {b['lo']:g}–{b['hi']:g} | {100 * b['pixel_share']:.1f} | {100 * b['sse_share']:.1f} "
                  f"| {b['rmse']:.2f} | {b['bias']:+.2f} |")
        rows.append(row)
    print(json.dumps(rows))
    return rows


if __name__ == "__main__":
    main()
