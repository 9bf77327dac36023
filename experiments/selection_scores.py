"""Score saved or shipped models and classical methods on the selection frames, per protocol.

The selection frames of ``experiments/pretrained_selection.py`` (drive 9001, frames
56-67, seed 0) under each occlusion protocol: the sel tables of ``docs/model_card.md``.

Examples
--------
    python experiments/selection_scores.py --kitti-root <KITTI root> kitti-mixed-v1 selection-runs/relative
    python experiments/selection_scores.py --kitti-root <KITTI root> -m harmonic -m harmonic-inverse
    python experiments/selection_scores.py --kitti-root <KITTI root> kitti-rect-v3+kitti-mixed-v1 --protocol rect-v1

A model is a shipped release of any family (see ``estimators.learned.releases.shipped``) or
a directory written by ``est.save`` or ``inpaintenv train``; ``a+b`` averages models' predictions.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable

import numpy as np
from _common import N_TRAIN, SELECTION_DRIVE, sel_scores

from estimators.learned import load_checkpoint
from estimators.learned.releases import load_release, shipped
from inpaintenv.data.kitti import KittiDepth
from inpaintenv.registry import make_method

PROTOCOLS = ("rect-v1", "lidar-dropout-v1", "ego-occlusion-v1", "freeform-v1")


def batch_predictor(label: str, kind: str) -> Callable[[np.ndarray], np.ndarray]:
    """``(N, H, W)`` corrupted -> filled, for a model (shipped name or saved directory) or a registry method.

    ``"a+b"`` is the mean of the predictions of models ``a`` and ``b`` (an ensemble).
    """
    if kind == "model" and "+" in label:
        members = [batch_predictor(part, kind) for part in label.split("+")]
        return lambda x: np.mean([predict(x) for predict in members], axis=0)
    if kind == "model":  # any shipped release by name, or any saved model folder
        est = load_release(label) if label in shipped() else load_checkpoint(label)
        return est.set_params(num_threads=1).predict
    if kind != "method":
        raise ValueError(f"kind must be 'model' or 'method', got {kind!r}")
    est = make_method(label)
    return lambda x: np.stack([est.predict(f) for f in x])


def main(argv: list[str] | None = None) -> list[dict]:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
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


if __name__ == "__main__":
    main()
