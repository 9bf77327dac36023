"""Two learned models and the mean of their predictions, against the classical fills, on the same frames.

Each model and the per-pixel mean of the two are scored with the classical methods in one
evaluation (the benchmark's masks: frame ``i`` of the selected frames under seed ``s``), and
each learned entry is printed over the strongest classical method with its paired 95 %
interval, pooled over the frames (:func:`inpaintenv.benchmark.headline.learned_vs_classical`).
It measures whether two models of different families err in different places: a mean that
beats both is the case for an ensemble of the two. Score models on frames neither was trained
on, e.g. a leave-one-day-out fold model of ``experiments/lodo_days.sh`` and a release trained
on other days.

Examples
--------
    python experiments/mean_of_models.py --kitti-root <KITTI root> --day 2011_10_03 \\
        lodo/train-day-2011_10_03-context-kitti-draws/model kitti-rect-v4 -m harmonic -m scanline
    python experiments/mean_of_models.py --kitti-root <KITTI root> --day 2011_10_03 --shared-features \\
        --set-second tta=false lodo/train-day-2011_10_03-context-kitti-draws/model \\
        lodo-blend/train-day-2011_10_03-blend-kitti/model -m harmonic -m scanline

``--shared-features`` computes the candidate features once for both models (blend estimators
that read the same candidates), as the ensemble release of the two does
(``estimators.MeanEnsembleInpainter``); the ms/frame column
comes from the same run (one untimed warm-up call per method).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np

from estimators import MeanEnsembleInpainter
from inpaintenv.benchmark.headline import CLASSICAL_METHODS, learned_vs_classical
from inpaintenv.data.kitti import KittiDepth
from inpaintenv.evaluate import evaluate
from inpaintenv.registry import make_method
from inpaintenv.report.results import EvaluationResult


class MeanOfModels:
    """Per-pixel mean of the predictions of ``models`` (each with ``predict``)."""

    def __init__(self, models: list[Any]) -> None:
        if len(models) < 2:
            raise ValueError(f"a mean needs at least two models, got {len(models)}")
        self.models = models

    def predict(self, depth: np.ndarray) -> np.ndarray:
        return np.mean([np.asarray(m.predict(depth), dtype=np.float32) for m in self.models], axis=0)


def load_method(spec: str) -> tuple[str, Any]:
    """``(name, method)`` of a saved model folder (named after its run folder) or a registry name."""
    path = Path(spec)
    if path.is_dir():
        run = path.parent.name if path.name == "model" else path.name
        return run, make_method("checkpoint", path=path)
    return spec, make_method(spec)


def shared_feature_mean(models: list[Any]) -> MeanEnsembleInpainter:
    """The mean of blend estimators that read the same candidate features, computed once per
    frame for all of them: the product's :class:`~estimators.MeanEnsembleInpainter`
    of the fitted models (what an ensemble release of them costs)."""
    others = [type(m).__name__ for m in models if not hasattr(m, "_predict_features")]
    if others:
        raise ValueError(f"shared features need blend estimators; not one: {', '.join(others)}")
    reads = {(tuple(m.candidates), bool(m.endpoints)) for m in models}
    if len(reads) != 1:
        raise ValueError(f"the models do not read the same candidate features: {sorted(reads)}")
    return MeanEnsembleInpainter.from_fitted([(f"model{k}", m) for k, m in enumerate(models)],
                                             predict_threads=models[0].predict_threads)


def main(argv: list[str] | None = None) -> list[dict]:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("models", nargs=2, help="two saved model folders or registry names of learned methods")
    p.add_argument("-m", "--method", action="append", default=[], help="classical registry method (repeatable)")
    p.add_argument("--kitti-root", required=True)
    p.add_argument("--split", default="train")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--drive", action="append", help="a drive to score (repeatable)")
    where.add_argument("--day", help="score every drive of this recording day, e.g. 2011_10_03")
    p.add_argument("--camera", default="image_02")
    p.add_argument("--seed", type=int, action="append", help="mask seed (repeatable; default 0 and 1)")
    p.add_argument("--protocol", default="rect-v1")
    p.add_argument("--set-second", action="append", default=[], metavar="KEY=VALUE",
                   help="a prediction parameter of the second model, VALUE in JSON (e.g. tta=false; repeatable)")
    p.add_argument("--shared-features", action="store_true",
                   help="the mean computes the candidate features once for both models (blend estimators)")
    args = p.parse_args(argv)
    unknown = [m for m in args.method if m not in CLASSICAL_METHODS]
    if not args.method or unknown:
        p.error("-m takes one or more classical methods (the ratio's denominator)"
                + (f"; not classical: {', '.join(unknown)}" if unknown else ""))
    drives = args.drive
    if args.day:
        drives = sorted({str(g) for g in KittiDepth(args.kitti_root, split=args.split).groups
                         if str(g).startswith(args.day)})
        if not drives:
            p.error(f"no {args.split} drive of day {args.day}")
    frames = KittiDepth(args.kitti_root, split=args.split, drives=drives, camera=args.camera)
    (name_a, a), (name_b, b) = (load_method(m) for m in args.models)
    for item in args.set_second:
        key, sep, value = item.partition("=")
        try:
            b.set_params(**{key: json.loads(value)})
        except (ValueError, TypeError) as exc:  # no "=", bad JSON, or not a parameter of the model
            p.error(f"--set-second {item!r}: {exc}" if sep else f"--set-second takes KEY=VALUE, got {item!r}")
        name_b += f" ({key}={value})"
    if name_a == name_b:
        name_b += "-2"
    mean = shared_feature_mean([a, b]) if args.shared_features else MeanOfModels([a, b])
    learned = [(name_a, a), (name_b, b), ("mean", mean)]
    seeds = args.seed or [0, 1]
    rows: list[dict] = []
    for name, method in learned + [(m, make_method(m)) for m in args.method]:
        rows += evaluate(method, frames, args.protocol, seeds, name=name, progress=False, warmup=True).rows
    entries = []
    ms = {m: float(np.median([r["ms"] for r in rows if r["method"] == m])) for m in {r["method"] for r in rows}}
    print("| learned | hole RMSE | strongest classical | ratio [paired 95 %] | frame-masks | ms/frame (median) |")
    print("|---|---:|---|---:|---:|---:|")
    for name, _ in learned:
        keep = set(args.method) | {name}
        entry = learned_vs_classical(EvaluationResult(rows=[r for r in rows if r["method"] in keep]),
                                     keys=("protocol",))[0]
        entries.append(entry)
        print(f"| {name} | {entry['learned_hole_rmse']:.2f} m | {entry['classical']} {entry['classical_hole_rmse']:.2f} m "
              f"| {entry['hole_ratio']:.3f} [{entry['hole_ratio_low']:.2f}, {entry['hole_ratio_high']:.2f}] "
              f"| {entry['hole_ratio_n']} | {ms[name]:.0f} |")
    print("\nms/frame (median) of the classical methods: "
          + ", ".join(f"{m} {ms[m]:.0f}" for m in args.method))
    return entries


if __name__ == "__main__":
    main()
