"""The two recipes' fold models of ``kitti-ensemble-v1``: joined into an ensemble, their mean
scored, a fold's drives pooled.

* ``join``: join saved models into one ``MeanEnsembleInpainter`` checkpoint (formerly ``join_models.py``).
* ``mean``: two learned models and the per-pixel mean of their predictions
  against the classical fills (formerly ``mean_of_models.py``).
* ``pooled``: the learned-vs-classical headline of benchmark run folders,
  pooled over their drives (formerly ``pooled_headline.py``).

``python experiments/fold_ensemble.py COMMAND --help`` prints a command's options.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np
from _common import exit_status, run_command

from estimators.learned import MeanEnsembleInpainter, load
from inpaintenv.benchmark.headline import CLASSICAL_METHODS, headline_markdown, learned_vs_classical
from inpaintenv.data.kitti import KittiDepth
from inpaintenv.evaluate import evaluate
from inpaintenv.files import loads_json
from inpaintenv.methods.registry import make_method
from inpaintenv.report.results import EvaluationResult


JOIN_DOC = """Join saved learned models into one MeanEnsembleInpainter checkpoint, e.g. two fold models of a fold.

``inpaintenv train --preset ensemble-kitti`` trains both members of the ensemble on the same
frames, one after the other. Where each member's recipe was already trained on a fold (two
runs of ``experiments/lodo_days.sh``, one per preset), joining the two saved models gives the
ensemble of that fold without training again: each member is the model its own preset trains.
The joined folder loads with ``inpaintenv benchmark --checkpoint NAME=OUT``.

Examples
--------
    python experiments/fold_ensemble.py join --out lodo-ensemble/train-day-2011_10_03-ensemble-kitti/model \\
        context=lodo-draws-s1/train-day-2011_10_03-context-kitti-draws/model \\
        blend=lodo-blend/train-day-2011_10_03-blend-kitti/model --set blend__tta=false
"""


def join_command(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="fold_ensemble.py join", description=JOIN_DOC.split("\n\n")[0])
    p.add_argument("members", nargs="+", metavar="NAME=FOLDER", help="a member's name and saved model folder")
    p.add_argument("--out", required=True, help="folder of the joined checkpoint")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="a prediction parameter, VALUE in JSON: the ensemble's or a member's as name__key "
                        "(e.g. blend__tta=false; repeatable)")
    args = p.parse_args(argv)
    members = []
    for item in args.members:
        name, sep, folder = item.partition("=")
        if not sep or not name or not folder:
            p.error(f"a member is NAME=FOLDER, got {item!r}")
        try:
            members.append((name, load(folder)))
        except (ValueError, OSError) as exc:  # not a model folder, or an unreadable one
            p.error(f"member {name}: {exc}")
    try:
        est = MeanEnsembleInpainter.from_fitted(members)
        for item in args.set:
            key, sep, value = item.partition("=")
            if not sep:
                p.error(f"--set takes KEY=VALUE, got {item!r}")
            est.set_params(**{key: loads_json(value, f"--set {key}")})
    except (ValueError, TypeError) as exc:
        p.error(str(exc))
    print(f"joined {', '.join(n for n, _ in members)} -> {est.save(args.out)}")
    return 0


MEAN_DOC = """Two learned models and the mean of their predictions, against the classical fills, on the same frames.

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
    python experiments/fold_ensemble.py mean --kitti-root <KITTI root> --day 2011_10_03 \\
        lodo/train-day-2011_10_03-context-kitti-draws/model kitti-rect-v4 -m harmonic -m scanline
    python experiments/fold_ensemble.py mean --kitti-root <KITTI root> --day 2011_10_03 --shared-features \\
        --set-second tta=false lodo/train-day-2011_10_03-context-kitti-draws/model \\
        lodo-blend/train-day-2011_10_03-blend-kitti/model -m harmonic -m scanline

``--shared-features`` computes the candidate features once for both models (blend estimators
that read the same candidates), as the ensemble release of the two does
(``estimators.learned.MeanEnsembleInpainter``); the ms/frame column
comes from the same run (one untimed warm-up call per method).
"""


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
    frame for all of them: the product's :class:`~estimators.learned.MeanEnsembleInpainter`
    of the fitted models (what an ensemble release of them costs)."""
    others = [type(m).__name__ for m in models if not hasattr(m, "_predict_features")]
    if others:
        raise ValueError(f"shared features need blend estimators; not one: {', '.join(others)}")
    reads = {(tuple(m.candidates), bool(m.endpoints)) for m in models}
    if len(reads) != 1:
        raise ValueError(f"the models do not read the same candidate features: {sorted(reads)}")
    return MeanEnsembleInpainter.from_fitted([(f"model{k}", m) for k, m in enumerate(models)],
                                             predict_threads=models[0].predict_threads)

def mean_command(argv: list[str] | None = None) -> list[dict]:
    p = argparse.ArgumentParser(prog="fold_ensemble.py mean", description=MEAN_DOC.split("\n\n")[0])
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
            b.set_params(**{key: loads_json(value, f"--set {key}")})
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


POOLED_DOC = """The learned-vs-classical headline of benchmark run folders, pooled over their drives.

``inpaintenv benchmark`` prints the headline per drive; a fold that leaves out a whole
recording day (``experiments/lodo_days.sh``) is judged on all of that day's frames at
once: the strongest classical method is the one with the lowest mean hole RMSE over the
fold's frame-masks, and the ratio's paired 95 % interval resamples them
(:func:`inpaintenv.benchmark.headline.learned_vs_classical` with ``keys=("protocol",)``).

Examples
--------
    python experiments/fold_ensemble.py pooled lodo-days/bench-day-2011_09_30 lodo-days/bench-drive-0001
    python experiments/fold_ensemble.py pooled lodo-days/bench-day-2011_09_30 --learned kitti-rect-v4

``--learned NAME`` compares that learned method alone (the run's other learned methods
left out) instead of the best learned method of the run. ``--gate-ceiling`` adds what a
per-frame fall-back gate could reach at best: each frame-mask scored by whichever of the
learned method and the run's classical methods did best on it, with hindsight, over the
strongest classical method's mean, and the share of frame-masks on which the learned method
is worse than the best classical one.
"""


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

def pooled_command(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="fold_ensemble.py pooled", description=POOLED_DOC.split("\n\n")[0])
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


COMMANDS = {"join": join_command, "mean": mean_command, "pooled": pooled_command}


def main(argv: list[str] | None = None) -> Any:
    """Run the command named by ``argv[0]`` (see the module docstring)."""
    return run_command("fold_ensemble.py", COMMANDS, argv)


if __name__ == "__main__":
    sys.exit(exit_status(main()))
