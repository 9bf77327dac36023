"""Nested choice between two training recipes and the per-pixel mean of their models, by inner folds over days.

The folds of ``experiments/lodo_days.sh`` are reported: each recording day left out, and
drive 2011_09_26_drive_0001_sync (official maps) left out. Choosing a recipe on those frames
would make the report a selection score. Here each fold chooses on its own training data only:
an inner split leaves out one of the fold's training days (for the drive-0001 fold, one day
without drive 0001), trains both recipes on the rest with ``inpaintenv train`` and scores
three candidates on the split's held-out drives:

* ``first``: the first recipe's model (default ``context-kitti-draws``, kitti-context-v3's);
* ``second``: the second recipe's model (default ``blend-kitti``, kitti-rect-v4's);
* ``mean``: the per-pixel mean of the two, the second without its mirrored pass
  (``--second-tta``), features computed once for both (``MeanEnsembleInpainter``).

``--weight W`` (repeatable) adds the candidate ``mean-wW``: the weighted mean, the first model
weighing ``W`` and the second ``1 - W`` (``MeanEnsembleInpainter(weights=...)``). A rerun with
the same seeds reuses the rows of ``OUT/inner-<fold>.json`` and scores only what is new.
``--share METHOD:S`` (repeatable) adds ``mean+METHOD-sS``: ``(1 - S)`` times the mean plus ``S``
times a classical fill, per pixel (``METHOD`` from ``-m``): whether a classical fill that wins
some unseen scenes (scanline in open country) corrects the learned mean there without costing
more elsewhere. Each frame's mean and classical predictions are computed once per run and
shared by all candidates that read them. ``--gate METHOD:S:T`` (repeatable) adds
``mean+METHOD-sS-if-farther-T``: that mix only on the frames where the classical fill lies
farther than the mean (median log ratio over the hole above ``T``), the mean elsewhere.
``--outer`` also scores every mean candidate on the fold's reported frames (its ``lodo_days.sh``
fold models, from ``--link``), so the chosen candidate's reported ratio is printed too; the rows
land in ``OUT/outer-<fold>.json`` (``--by-drive`` prints their ratios per drive).

Each candidate's ratio to the strongest classical method (``-m``) is pooled over the fold's
inner splits (every held-out frame-mask counts once, paired 95 % interval); the lowest ratio
is the fold's choice. The fold's report is then the chosen candidate's score on the outer
held-out frames, which ``lodo_days.sh`` and ``fold_ensemble.py mean`` measure (``--outer``
prints it for the mean candidates).

Models land in ``OUT/train-without-<left-out>-<preset>/model``; one training set shared by
several inner splits is trained once, and a rerun resumes. ``--link DIR`` reuses
``lodo_days.sh`` fold models of ``DIR`` where a split's training set is one of its folds'.

Examples
--------
    python experiments/nested_mean.py --kitti-root <KITTI root> --out nested --train --jobs 2 \\
        --link lodo-draws-s1 --link lodo-blend -m harmonic -m scanline
    python experiments/nested_mean.py --kitti-root <KITTI root> --out nested --link lodo-draws-s1 \\
        --link lodo-blend -m harmonic -m scanline --weight 0.3 --weight 0.7 --outer
"""

from __future__ import annotations

import argparse
import hashlib
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from estimators.learned import MeanEnsembleInpainter, load
from inpaintenv.benchmark.headline import CLASSICAL_METHODS, learned_vs_classical
from inpaintenv.data.kitti import KittiDepth
from inpaintenv.evaluate import evaluate
from inpaintenv.files import read_json, write_json
from inpaintenv.methods.registry import make_method
from inpaintenv.report.results import EvaluationResult, parse_row

OFFICIAL = "2011_09_26_drive_0001_sync"
CANDIDATES = ("first", "second", "mean")


class Memo:
    """``method``'s predictions, each computed once per distinct input batch (mixed candidates
    re-read them)."""

    def __init__(self, method: Any) -> None:
        self.method = method
        self.cache: dict[bytes, np.ndarray] = {}

    def predict(self, depth: np.ndarray) -> np.ndarray:
        depth = np.ascontiguousarray(depth)
        key = hashlib.blake2b(depth.tobytes(), digest_size=16).digest() + repr(depth.shape).encode()
        if key not in self.cache:
            self.cache[key] = np.asarray(self.method.predict(depth), dtype=np.float32)
        return self.cache[key]


class Mix:
    """``(1 - share)`` times ``first``'s prediction plus ``share`` times ``second``'s, per pixel.

    With ``farther_than`` set, only on the frames where ``second`` lies farther than ``first``:
    the median over the hole of ``log(second / first)`` exceeds it; ``first`` elsewhere. That
    gate reads the two predictions, never the ground truth. It asks whether the open-country
    failure (the learned fill too near where a row carries far depth across the hole) can be
    told from the frame itself.
    """

    def __init__(self, first: Memo, second: Memo, share: float, farther_than: float | None = None) -> None:
        self.first, self.second, self.share, self.farther_than = first, second, share, farther_than

    def predict(self, depth: np.ndarray) -> np.ndarray:
        first, second = self.first.predict(depth), self.second.predict(depth)
        mixed = (1 - self.share) * first + self.share * second
        if self.farther_than is None:
            return mixed
        out = first.copy()
        for k in range(depth.shape[0]):
            hole = np.isnan(depth[k])
            if hole.any() and np.median(np.log(np.maximum(second[k][hole], 0.1)
                                               / np.maximum(first[k][hole], 0.1))) > self.farther_than:
                out[k] = mixed[k]
        return out


def parse_mix(text: str, methods: list[str], *, gated: bool = False) -> tuple[Any, ...]:
    """``--share``'s ``"scanline:0.2"`` -> ``("scanline", 0.2)``, share in (0, 1); with ``gated``,
    ``--gate``'s ``"scanline:0.5:0.2"`` -> ``("scanline", 0.5, 0.2)``, share in (0, 1] and
    threshold (log ratio) >= 0. The method must be one of ``methods``."""
    parts = text.split(":")
    try:
        numbers = [float(x) for x in parts[1:]]
    except ValueError:
        numbers = []
    share_ok = bool(numbers) and (0 < numbers[0] <= 1 if gated else 0 < numbers[0] < 1)
    if (len(numbers) != (2 if gated else 1) or parts[0] not in methods or not share_ok
            or (gated and not numbers[1] >= 0)):
        form = "--gate takes METHOD:S:T" if gated else "--share takes METHOD:S"
        bounds = "S in (0, 1] and T >= 0" if gated else "S in (0, 1)"
        raise ValueError(f"{form} with METHOD one of -m ({', '.join(methods)}) and {bounds}, got {text!r}")
    return (parts[0], *numbers)


def mean_of(first: Any, second: Any) -> MeanEnsembleInpainter:
    """The product's per-pixel mean of two fitted models (blend models share their candidate features)."""
    return MeanEnsembleInpainter.from_fitted([("first", first), ("second", second)],
                                             predict_threads=first.predict_threads)


def day_of(drive: str) -> str:
    """Recording day of a KITTI drive name (``2011_09_26_drive_0001_sync`` -> ``2011_09_26``)."""
    return drive[:10]


def outer_folds(drives: list[str]) -> list[dict[str, Any]]:
    """The reported folds of ``lodo_days.sh``: each day left out, then drive 0001 (if present).

    Each fold has ``name``, ``held`` (drives left out of training and reported) and
    ``inner``: the inner splits, each ``{"day", "exclude", "score"}`` (drives left out of the
    split's training, drives it is scored on; image_02).
    """
    days = sorted({day_of(d) for d in drives})
    folds = []
    for day in days:
        held = [d for d in drives if day_of(d) == day]
        inner = [{"day": t, "exclude": held + [d for d in drives if day_of(d) == t],
                  "score": [d for d in drives if day_of(d) == t]} for t in days if t != day]
        folds.append({"name": f"day-{day}", "held": held, "inner": inner})
    if OFFICIAL in drives:
        inner = []
        for t in days:
            score = [d for d in drives if day_of(d) == t and d != OFFICIAL]
            if score:
                inner.append({"day": t, "exclude": [OFFICIAL] + score, "score": score})
        folds.append({"name": "drive-0001", "held": [OFFICIAL], "inner": inner})
    return folds


def training_tag(exclude: list[str], drives: list[str]) -> str:
    """Folder tag of a training set: the whole days it leaves out, and drive 0001 if alone."""
    parts = []
    for day in sorted({day_of(d) for d in drives}):
        of_day = {d for d in drives if day_of(d) == day}
        if of_day <= set(exclude):
            parts.append(day)
        elif of_day & set(exclude):
            parts += sorted(d.split("_drive_")[1][:4] for d in of_day & set(exclude))
    return "+".join(parts)


def lodo_folder(tag: str) -> str | None:
    """``lodo_days.sh``'s fold name whose training set a tag names, if any."""
    if "+" in tag:
        return None
    return "drive-0001" if tag == "0001" else f"day-{tag}"


def train_command(root: str, preset: str, exclude: list[str], out: Path, flags: list[str]) -> list[str]:
    return ["inpaintenv", "train", "--preset", preset, "--kitti-root", root, "--split", "train", "--camera", "both",
            "--exclude-drives", *exclude, "--out", str(out), "--quiet", *flags]


def build_parser() -> argparse.ArgumentParser:
    """The command line (see the module docstring)."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--kitti-root", required=True)
    p.add_argument("--out", required=True, help="folder of the inner models and results")
    p.add_argument("--presets", default="context-kitti-draws,blend-kitti", help="first,second training recipe")
    p.add_argument("--train", action="store_true", help="train the inner models that are missing")
    p.add_argument("--jobs", type=int, default=1, help="trainings at a time (separate processes)")
    p.add_argument("--train-flags", default="--threads 1 --jobs 1", help="options of every inpaintenv train")
    p.add_argument("--link", action="append", default=[], metavar="DIR",
                   help="a lodo_days.sh output folder whose fold models are reused (repeatable)")
    p.add_argument("--fold", action="append", help="only these outer folds (e.g. day-2011_10_03; repeatable)")
    p.add_argument("-m", "--method", action="append", default=[], help="classical registry method (repeatable)")
    p.add_argument("--seed", type=int, action="append", help="mask seed (repeatable; default 0 and 1)")
    p.add_argument("--protocol", default="rect-v1")
    p.add_argument("--second-tta", choices=("false", "true"), default="false",
                   help="the second model's mirrored pass inside the mean (default false)")
    p.add_argument("--weight", type=float, action="append", default=[], metavar="W",
                   help="add the weighted mean, the first model weighing W in (0, 1) (repeatable)")
    p.add_argument("--share", action="append", default=[], metavar="METHOD:S",
                   help="add (1 - S) x mean + S x the classical METHOD (one of -m; repeatable)")
    p.add_argument("--gate", action="append", default=[], metavar="METHOD:S:T",
                   help="add the share S of METHOD on the frames where it is farther than the mean "
                        "(median log ratio over the hole > T; repeatable)")
    p.add_argument("--outer", action="store_true",
                   help="also score the mean candidates on each fold's reported frames (its --link fold models)")
    p.add_argument("--by-drive", action="store_true", help="with --outer: each mean candidate's ratio per drive")
    return p


def parse_args(p: argparse.ArgumentParser, argv: list[str] | None) -> argparse.Namespace:
    """The checked options, with ``shares``, ``gates``, ``candidates`` and ``presets`` added."""
    args = p.parse_args(argv)
    if args.by_drive and not args.outer:
        p.error("--by-drive reads the reported rows: give --outer too")
    if any(not 0 < w < 1 for w in args.weight):
        p.error(f"--weight takes numbers between 0 and 1, got {args.weight}")
    unknown = [m for m in args.method if m not in CLASSICAL_METHODS]
    if not args.method or unknown:
        p.error("-m takes one or more classical methods" + (f"; not classical: {', '.join(unknown)}" if unknown else ""))
    try:
        args.shares = [parse_mix(text, args.method) for text in args.share]
        args.gates = [parse_mix(text, args.method, gated=True) for text in args.gate]
    except ValueError as err:
        p.error(str(err))
    args.candidates = (CANDIDATES + tuple(f"mean-w{w:g}" for w in args.weight)
                       + tuple(f"mean+{m}-s{s:g}" for m, s in args.shares)
                       + tuple(f"mean+{m}-s{s:g}-if-farther-{t:g}" for m, s, t in args.gates))
    args.presets = args.presets.split(",")
    if len(args.presets) != 2:
        p.error(f"--presets takes two recipes, got {','.join(args.presets)!r}")
    args.seeds = args.seed or [0, 1]
    return args


class NestedChoice:
    """One run over the outer folds: where each training set's models are, and how candidates score."""

    def __init__(self, args: argparse.Namespace, drives: list[str]) -> None:
        self.args, self.drives, self.out = args, drives, Path(args.out)

    def model_dir(self, exclude: list[str], preset: str) -> Path:
        """The model of ``preset`` trained without ``exclude``: this run's own, or a linked lodo_days.sh fold's."""
        tag = training_tag(exclude, self.drives)
        own = self.out / f"train-without-{tag}-{preset}" / "model"
        lodo = lodo_folder(tag)
        for linked in self.args.link:
            candidate = Path(linked) / f"train-{lodo}-{preset}" / "model"
            if lodo and not (own / "config.json").is_file() and (candidate / "config.json").is_file():
                return candidate
        return own

    def train_missing(self, folds: list[dict[str, Any]]) -> int:
        """Train the inner models that are missing (with ``--train``); 1 with a message if any is left."""
        args = self.args
        needed = {(str(self.model_dir(s["exclude"], pr)), pr): s["exclude"]
                  for f in folds for s in f["inner"] for pr in args.presets}
        missing = [(Path(d), pr, ex) for (d, pr), ex in needed.items() if not (Path(d) / "config.json").is_file()]
        if missing and not args.train:
            print("missing inner models (rerun with --train):\n  " + "\n  ".join(str(d) for d, _, _ in missing),
                  file=sys.stderr)
            return 1
        if missing:
            commands = [train_command(args.kitti_root, pr, ex, d.parent, args.train_flags.split())
                        for d, pr, ex in missing]
            with ThreadPoolExecutor(max(1, args.jobs)) as pool:
                codes = list(pool.map(lambda c: subprocess.run(c, check=False).returncode, commands))
            failed = [" ".join(c) for c, rc in zip(commands, codes) if rc]
            if failed:
                print("training failed:\n  " + "\n  ".join(failed), file=sys.stderr)
                return 1
        return 0

    def scored(self, exclude: list[str], frames: KittiDepth, wanted: set[str]) -> list[dict]:
        """Rows of the candidates in ``wanted`` (and classical methods) built from the models of ``exclude``."""
        args = self.args
        first = load(self.model_dir(exclude, args.presets[0]))
        in_mean = load(self.model_dir(exclude, args.presets[1]))
        in_mean.set_params(tta=args.second_tta == "true")
        mean = Memo(mean_of(first, in_mean))
        methods: dict[str, Any] = {"first": first, "mean": mean}
        if "second" in wanted:  # the second model on its own, with its mirrored pass as saved
            methods["second"] = load(self.model_dir(exclude, args.presets[1]))
        for w in args.weight:
            methods[f"mean-w{w:g}"] = mean_of(first, in_mean).set_params(weights=[w, 1 - w])
        classical = {m: Memo(make_method(m)) for m in args.method}
        methods.update(classical)
        for m, share in args.shares:
            methods[f"mean+{m}-s{share:g}"] = Mix(mean, classical[m], share)
        for m, share, threshold in args.gates:
            methods[f"mean+{m}-s{share:g}-if-farther-{threshold:g}"] = Mix(mean, classical[m], share, threshold)
        rows = []
        for name in [m for m in methods if m in wanted]:
            rows += evaluate(methods[name], frames, args.protocol, args.seeds, name=name, progress=False).rows
        return rows

    def pooled(self, rows: list[dict], cand: str, by_drive: bool = False) -> Any:
        """``cand``'s hole-RMSE ratio to the strongest of the classical methods over ``rows``
        (with ``by_drive``: one entry per drive)."""
        keep = set(self.args.method) | {cand}
        entries = learned_vs_classical(EvaluationResult(rows=[r for r in rows if r["method"] in keep]),
                                       keys=("protocol", "drive") if by_drive else ("protocol",))
        return entries if by_drive else entries[0]

    def outer_ratios(self, fold: dict[str, Any], choice: str) -> dict[str, float]:
        """The mean candidates on the fold's reported frames (its lodo_days.sh models), printed."""
        args = self.args
        camera = "both" if fold["name"] == "drive-0001" else "image_02"
        frames = KittiDepth(args.kitti_root, split="train", drives=fold["held"], camera=camera)
        means = [c for c in args.candidates if c.startswith("mean")]
        rows = self.scored(fold["held"], frames, set(means) | set(args.method))
        self.out.mkdir(parents=True, exist_ok=True)
        EvaluationResult(rows=rows).to_json(self.out / f"outer-{fold['name']}.json")  # per-drive reading
        print(f"\nreported frames of fold {fold['name']} (its lodo_days.sh models):\n")
        if choice not in means:  # a single model: its reported ratio is lodo_days.sh's benchmark
            print(f"(chosen: {choice}, a single model; its reported ratio is lodo_days.sh's)\n")
        print("| candidate | ratio [paired 95 %] | frame-masks |\n|---|---:|---:|")
        ratios = {}
        for cand in means:
            e = self.pooled(rows, cand)
            ratios[cand] = e["hole_ratio"]
            print(f"| {cand}{' (chosen)' if cand == choice else ''} | {e['hole_ratio']:.3f} "
                  f"[{e['hole_ratio_low']:.2f}, {e['hole_ratio_high']:.2f}] | {e['hole_ratio_n']} |", flush=True)
        if args.by_drive:
            print("\n| drive | " + " | ".join(means) + " |\n|---|" + "---:|" * len(means))
            per_drive = {c: {e["drive"]: e["hole_ratio"] for e in self.pooled(rows, c, by_drive=True)} for c in means}
            for drive in sorted({r["drive"] for r in rows}):
                print(f"| {drive} | " + " | ".join(f"{per_drive[c][drive]:.3f}" for c in means) + " |")
        return ratios

    def inner_rows(self, fold: dict[str, Any]) -> list[dict]:
        """Every candidate's rows on the fold's inner splits: those saved by an earlier run, and the rest."""
        args = self.args
        saved = self.out / f"inner-{fold['name']}.json"
        rows: list[dict] = []
        if saved.is_file():  # a rerun scores only the candidates (or seeds) not yet there
            # The split's day is this experiment's own column: a row is checked without it.
            rows = [{**parse_row({k: v for k, v in r.items() if k != "split"}), "split": r["split"]}
                    for r in read_json(saved, "inner rows")["rows"] if int(r["seed"]) in args.seeds]
        for n, split in enumerate(fold["inner"]):
            done = {r["method"] for r in rows if r["split"] == split["day"]}
            wanted = (set(args.candidates) | set(args.method)) - done
            if not wanted:
                continue
            frames = KittiDepth(args.kitti_root, split="train", drives=split["score"], camera="image_02")
            for r in self.scored(split["exclude"], frames, wanted):
                # frame-masks of different splits must not pair with each other
                rows.append({**r, "index": n * 1_000_000 + int(r["index"]), "split": split["day"]})
        self.out.mkdir(parents=True, exist_ok=True)
        EvaluationResult(rows=rows).to_json(saved)
        return rows

    def choose(self, fold: dict[str, Any]) -> dict[str, Any]:
        """The fold's choice among the candidates on its inner splits, printed; with ``--outer``, its report."""
        candidates = self.args.candidates
        rows = self.inner_rows(fold)
        entries = {cand: self.pooled(rows, cand) for cand in candidates}
        choice = min(candidates, key=lambda c: entries[c]["hole_ratio"])
        print(f"\n## fold {fold['name']}: inner splits leave out {', '.join(s['day'] for s in fold['inner'])}\n")
        print("| candidate | hole RMSE | strongest classical | ratio [paired 95 %] | frame-masks |")
        print("|---|---:|---|---:|---:|")
        for cand in candidates:
            e = entries[cand]
            print(f"| {cand}{' (chosen)' if cand == choice else ''} | {e['learned_hole_rmse']:.2f} m "
                  f"| {e['classical']} {e['classical_hole_rmse']:.2f} m | {e['hole_ratio']:.3f} "
                  f"[{e['hole_ratio_low']:.2f}, {e['hole_ratio_high']:.2f}] | {e['hole_ratio_n']} |", flush=True)
        summary = {"fold": fold["name"], "choice": choice, "inner": [s["day"] for s in fold["inner"]],
                   "ratios": {c: entries[c]["hole_ratio"] for c in candidates}}
        if self.args.outer:
            summary["outer"] = self.outer_ratios(fold, choice)
        return summary


def main(argv: list[str] | None = None) -> int:
    p = build_parser()
    args = parse_args(p, argv)
    drives = sorted({str(g) for g in KittiDepth(args.kitti_root, split="train").groups})
    folds = [f for f in outer_folds(drives) if not args.fold or f["name"] in args.fold]
    if not folds:
        p.error(f"no such fold: {args.fold}")
    run = NestedChoice(args, drives)
    if run.train_missing(folds):
        return 1
    summary = [run.choose(fold) for fold in folds]
    write_json(run.out / "choices.json", summary)
    print("\nchoices: " + ", ".join(f"{s['fold']} {s['choice']}" for s in summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())
