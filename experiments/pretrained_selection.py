"""Train a variant of the shipped model's recipe and score it on the selection frames.

The selection protocol of ``docs/model_card.md``: train on frames 0-55 of drive
``2011_09_26_drive_9001_sync`` (ids 5-60), score hole/all RMSE on its frames 56-67
(ids 61-72, rect-v1, seed 0). Never on the drives reported as unseen.

Examples
--------
    python experiments/pretrained_selection.py v2 --kitti-root <KITTI root> \\
        'candidates=("scanline","scanline-inverse","vertical","harmonic","vertical-inverse","harmonic-inverse")' \\
        max_steps=900 num_threads=1
    python experiments/pretrained_selection.py v1 --kitti-root <KITTI root> --preset cpu-1h-v1

Overrides are ``name=value`` with a Python literal value, applied to the preset.
"""

from __future__ import annotations

import argparse
import ast
import json
import time
from pathlib import Path

from _common import N_TRAIN, SELECTION_DRIVE, sel_scores

from estimators.learned.presets import make_preset
from inpaintenv.data import ArrayDataset, ConcatDataset, SyntheticStreets
from inpaintenv.data.kitti import KittiDepth


def main(argv: list[str] | None = None) -> dict:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("name", help="label of the run; the model is saved under --out/NAME")
    p.add_argument("overrides", nargs="*", help="name=value (Python literal)")
    p.add_argument("--kitti-root", required=True)
    p.add_argument("--preset", default="cpu-1h")
    p.add_argument("--out", default="selection-runs")
    p.add_argument("--synthetic", type=int, default=0, metavar="N",
                   help="append N SyntheticStreets frames (seed 1000) to the training frames")
    args = p.parse_intermixed_args(argv)  # overrides may come after the options
    overrides = {}
    for item in args.overrides:
        key, sep, value = item.partition("=")
        if not sep:
            p.error(f"override {item!r} is not name=value")
        overrides[key] = ast.literal_eval(value)

    frames = KittiDepth(args.kitti_root, split="train", drives=[SELECTION_DRIVE])
    train = ArrayDataset(frames.load_batch(range(N_TRAIN)))
    if args.synthetic:
        # Procedural streets add scene diversity the one real drive lacks; seed 1000
        # keeps them apart from the synthetic frames the tests and demos use.
        train = ConcatDataset([train, SyntheticStreets(n=args.synthetic, seed=1000, frame_shape=frames.frame_shape)])
    sel = frames.load_batch(range(N_TRAIN, len(frames)))
    est = make_preset(args.preset, **overrides)
    start = time.perf_counter()
    est.fit(train)
    train_s = time.perf_counter() - start
    est.save(Path(args.out) / args.name)

    scores = sel_scores(est.predict, sel)
    row = {"name": args.name, "preset": args.preset, "overrides": {k: repr(v) for k, v in overrides.items()},
           "synthetic": args.synthetic,
           "train_s": round(train_s), "sel_hole_rmse": round(float(scores["hole_rmse"]), 3),
           "sel_all_rmse": round(float(scores["all_rmse"]), 3)}
    print(json.dumps(row))
    return row


if __name__ == "__main__":
    main()
