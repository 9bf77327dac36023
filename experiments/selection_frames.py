"""The selection frames of ``kitti-mixed-v1`` (drive 9001, frames 56-67, seed 0): train a
variant of a recipe on the frames before them, score models on them per protocol.

* ``train``: train a variant of a preset and score it on the selection frames (formerly ``pretrained_selection.py``).
* ``score``: score shipped releases, saved runs and classical methods per
  protocol (formerly ``selection_scores.py``).

``python experiments/selection_frames.py COMMAND --help`` prints a command's options.
"""

from __future__ import annotations

import argparse
import ast
import json
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from _common import N_TRAIN, SELECTION_DRIVE, exit_status, run_command, sel_scores

from estimators.learned import load
from estimators.learned.presets import make_preset
from estimators.learned import load_release
from inpaintenv.methods.learned import shipped
from inpaintenv.data import ArrayDataset, ConcatDataset, SyntheticStreets
from inpaintenv.data.kitti import KittiDepth
from inpaintenv.methods.registry import make_method


TRAIN_DOC = """Train a variant of the shipped model's recipe and score it on the selection frames.

The selection protocol of ``docs/model_card.md``: train on frames 0-55 of drive
``2011_09_26_drive_9001_sync`` (ids 5-60), score hole/all RMSE on its frames 56-67
(ids 61-72, rect-v1, seed 0). Never on the drives reported as unseen.

Examples
--------
    python experiments/selection_frames.py train v2 --kitti-root <KITTI root> \\
        'candidates=("scanline","scanline-inverse","vertical","harmonic","vertical-inverse","harmonic-inverse")' \\
        max_steps=900 num_threads=1
    python experiments/selection_frames.py train v1 --kitti-root <KITTI root> --preset cpu-1h-v1

Overrides are ``name=value`` with a Python literal value, applied to the preset.
"""


def train_command(argv: list[str] | None = None) -> dict:
    p = argparse.ArgumentParser(prog="selection_frames.py train", description=TRAIN_DOC.split("\n\n")[0])
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


SCORE_DOC = """Score saved or shipped models and classical methods on the selection frames, per protocol.

The selection frames of ``experiments/selection_frames.py train`` (drive 9001, frames
56-67, seed 0) under each occlusion protocol: the sel tables of ``docs/model_card.md``.

Examples
--------
    python experiments/selection_frames.py score --kitti-root <KITTI root> kitti-mixed-v1 selection-runs/relative
    python experiments/selection_frames.py score --kitti-root <KITTI root> -m harmonic -m harmonic-inverse
    python experiments/selection_frames.py score --kitti-root <KITTI root> kitti-rect-v3+kitti-mixed-v1 --protocol rect-v1

A model is a shipped release of any family (see ``inpaintenv.methods.learned.shipped``) or
a directory written by ``est.save`` or ``inpaintenv train``; ``a+b`` averages models' predictions.
"""


PROTOCOLS = ("rect-v1", "lidar-dropout-v1", "ego-occlusion-v1", "freeform-v1")

def batch_predictor(label: str, kind: str) -> Callable[[np.ndarray], np.ndarray]:
    """``(N, H, W)`` corrupted -> filled, for a model (shipped name or saved directory) or a registry method.

    ``"a+b"`` is the mean of the predictions of models ``a`` and ``b`` (an ensemble).
    """
    if kind == "model" and "+" in label:
        members = [batch_predictor(part, kind) for part in label.split("+")]
        return lambda x: np.mean([predict(x) for predict in members], axis=0)
    if kind == "model":  # any shipped release by name, or any saved model folder
        est = load_release(label) if label in shipped() else load(label)
        return est.set_params(num_threads=1).predict
    if kind != "method":
        raise ValueError(f"kind must be 'model' or 'method', got {kind!r}")
    est = make_method(label)
    return lambda x: np.stack([est.predict(f) for f in x])

def score_command(argv: list[str] | None = None) -> list[dict]:
    p = argparse.ArgumentParser(prog="selection_frames.py score", description=SCORE_DOC.split("\n\n")[0])
    p.add_argument("models", nargs="*", help="shipped model names or saved model directories")
    p.add_argument("-m", "--method", action="append", default=[], help="registry method (repeatable)")
    p.add_argument("--kitti-root", required=True)
    p.add_argument("--protocol", action="append", help=f"default: all of {PROTOCOLS}")
    args = p.parse_intermixed_args(argv)
    frames = KittiDepth(args.kitti_root, split="train", drives=[SELECTION_DRIVE])
    sel = frames.load_batch(range(N_TRAIN, len(frames)))
    rows = []
    entries = [(m, "model") for m in args.models] + [(m, "method") for m in args.method]
    for label, kind in entries:
        predict = batch_predictor(label, kind)
        row = {"name": label}
        for protocol in args.protocol or PROTOCOLS:
            scores = sel_scores(predict, sel, protocol)
            row[protocol] = [round(float(scores["hole_rmse"]), 3), round(float(scores["all_rmse"]), 3)]
        print(json.dumps(row), flush=True)
        rows.append(row)
    return rows


COMMANDS = {"train": train_command, "score": score_command}


def main(argv: list[str] | None = None) -> Any:
    """Run the command named by ``argv[0]`` (see the module docstring)."""
    return run_command("selection_frames.py", COMMANDS, argv)


if __name__ == "__main__":
    sys.exit(exit_status(main()))
