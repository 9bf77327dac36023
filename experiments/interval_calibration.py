"""The per-pixel intervals of a release from its leave-one-day-out fold models: the shipped
calibration, and the signals tried for it.

* ``calibrate``: write the interval calibration shipped with a release or a classical fill.
* ``signals``: which per-pixel signals rank a fold model's errors (formerly ``interval_signals.py``).
* ``lodo``: which calibration protocol serves both scan tasks, one recording day left out.

``python experiments/interval_calibration.py COMMAND --help`` prints a command's options.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from _common import (bin_labels, coverage_by_bin, edges_option, exit_status, frame_factors, interval_scores, pooled,
                     run_command, seeds_option)

from inpaintenv.data.inputs import INPUT_KINDS, INPUTS
from inpaintenv.values.interval_calibration import CONDITIONS


CALIBRATE_DOC = """The interval calibration shipped with a release: out-of-fold residuals of its leave-one-day-out fold models.

The release saw every drive of the slice, so no drive can calibrate it directly. Its three
fold models (the release's recipe, each trained without one recording day and a few
calibration drives: docs/model_card.md, "Per-pixel intervals") can: every drive but
2011_09_26_drive_0001 (``OFFICIAL_DRIVE``: its maps and scans are the official frames reported, never
calibrated on, whatever the input) is scored by the fold model trained without its whole day, and
``ConformalIntervalInpainter.fit_out_of_fold`` fits the scale and the quantiles on those
pooled residuals, then wraps the release. The result is written to
``estimators/pretrained/intervals/<release>.json`` (``--out`` to write elsewhere).

    python experiments/interval_calibration.py calibrate --kitti-root <KITTI root>         --fold 2011_09_26=<model without 2011_09_26> --fold 2011_09_30=<...> --fold 2011_10_03=<...>

A release that was trained on a few drives only (``kitti-mixed-v1``: frames of one drive) needs
no fold models: without ``--fold`` it is calibrated directly on every drive its
``training_drives_`` does not name, with its own masks protocol (``--protocol``)::

    python experiments/interval_calibration.py calibrate --kitti-root <KITTI root> --release kitti-mixed-v1 --protocol mixed-v1

A classical fill (``--release scanline``) saw no drive: it is calibrated the same way, on every drive
but drive 0001, and ships as ``<name>-intervals``::

    python experiments/interval_calibration.py calibrate --kitti-root <KITTI root> --release scanline --spread-method nearest

``--input scan`` calibrates a fill of a single LiDAR scan on the scans of the rebuilt drives
(each frame's ``velodyne_raw`` paired with its ground truth; protocol ``densify-v1`` by default:
every pixel the scan did not measure is scored; drive 0001, val and val_selection, the official frames,
never). The scan default (``SCAN_DEFAULT``) ships this way::

    python experiments/interval_calibration.py calibrate --kitti-root <KITTI root> --input scan --release harmonic-ipbasic --spread-method harmonic --frames-per-drive 0

``--protocol densify-v1+rect-v1`` pools both scan tasks (each task's pixels: the unmeasured ones,
the hole cut out of the scan), and ``--signals border depth spread far`` covers the pixels far
from any measurement and the near ones alike: how ``kitti-scan-v1`` ships (``lodo`` chose it).

Several ``--input`` kinds pool densities (each kind's frames one part of ``fit_out_of_fold``: each
fold model scores its day at every kind). ``pretrained``'s sparse route (``kitti-sparse-v1`` on
32/16/8-beam scans; its fold models from ``scan_lodo.py lodo --save-folds``, at the release's shrink)
ships this way, under a route's file that registers no ``kitti-sparse-v1-intervals`` for maps::

    python experiments/interval_calibration.py calibrate --kitti-root <KITTI root> --release kitti-sparse-v1 \
        --input scan-rings32-v1 scan-rings16-v1 scan-rings8-v1 --protocol densify-v1+rect-v1 \
        --spread-method nearest --signals border depth spread far --frames-per-drive 6 \
        --fold 2011_09_26=<fold> --fold 2011_09_30=<fold> --fold 2011_10_03=<fold> \
        --out estimators/pretrained/intervals/routes/sparse-kitti-sparse-v1.json
"""

#: Drive of the official maps and scans: reported, so never calibrated on (maps, scans, folds alike).
OFFICIAL_DRIVE = "2011_09_26_drive_0001_sync"


def calibrate_command(argv: list[str] | None = None) -> Path:
    parser = argparse.ArgumentParser(prog="interval_calibration.py calibrate", description=CALIBRATE_DOC, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--kitti-root", required=True)
    parser.add_argument("--release", default="kitti-ensemble-v1", help="a shipped release or a classical fill")
    parser.add_argument("--fold", action="append", default=[], metavar="DAY=MODEL",
                        help="a fold model trained without every drive of recording day DAY (repeatable)")
    parser.add_argument("--frames-per-drive", type=int, default=12, help="0 = every frame")
    parser.add_argument("--spread-method", default="scanline")
    parser.add_argument("--coverage", type=float, default=0.9)
    parser.add_argument("--protocol", help="masks protocol the calibration frames are occluded with (default "
                        "rect-v1 on maps, densify-v1 on scans)")
    parser.add_argument("--input", nargs="+", choices=INPUT_KINDS, default=["map"],
                        help="the input the release fills: a map with holes, or a single scan (the rebuilt drives' "
                        "scans) or its density variants; several scan kinds are pooled (a fill that saw no drive)")
    parser.add_argument("--signals", nargs="*", default=["border", "depth", "spread"],
                        help="scale signals (\"far\" too: SIGNALS of estimators.intervals)")
    parser.add_argument("--condition", choices=CONDITIONS, help="a quantile per bin of it (Mondrian conformal)")
    parser.add_argument("--condition-edges", type=edges_option, metavar="E1,E2,...", help="its bins' edges (default DEFAULT_EDGES)")
    parser.add_argument("--out", help="default estimators/pretrained/intervals/<release>.json")
    args = parser.parse_args(argv)
    scans = [INPUTS[k].separate for k in args.input]
    if len(args.input) > 1 and (not all(scans) or len(set(args.input)) < len(args.input)):
        raise SystemExit("several --input kinds: distinct scan kinds only (each fold model scores its day at each)")
    if args.condition_edges and not args.condition:
        raise SystemExit("--condition-edges: the bin edges of a --condition, none given")
    args.protocol = args.protocol or ("densify-v1" if scans[0] else "rect-v1")

    from estimators.intervals import ConformalIntervalInpainter
    from estimators.learned import load
    from inpaintenv.data import KittiDepth, spaced_per_drive
    from inpaintenv.methods.registry import make_method

    datasets = [KittiDepth(args.kitti_root, split="train", input=kind) for kind in args.input]
    dataset = datasets[0]
    drives = sorted({str(g) for g in dataset.groups} - {OFFICIAL_DRIVE})
    folds = []
    for entry in args.fold:
        day, _, path = entry.partition("=")
        model = load(path)
        mine = [d for d in drives if d.startswith(day)]
        if not mine:
            raise SystemExit(f"--fold {entry}: no drive of day {day!r} in {args.kitti_root}")
        folds += [(model, spaced_per_drive(ds, args.frames_per_drive, mine)) for ds in datasets]  # a part per kind
        print(f"{day}: {len(mine)} drives scored by {path}", flush=True)
    release = make_method(args.release)
    start = time.perf_counter()
    wrapper = ConformalIntervalInpainter(release, coverage=args.coverage, spread_method=args.spread_method,
                                         protocol=args.protocol, signals=tuple(args.signals), condition=args.condition,
                                         condition_edges=args.condition_edges)
    if folds:
        left = sorted(set(drives) - {str(g) for _, ds in folds for g in ds.groups})
        if left:
            raise SystemExit(f"no fold scores drives {left}: give a --fold for their day")
        wrapper.fit_out_of_fold(folds)
    else:
        unseen = sorted(set(drives) - set(getattr(release, "training_drives_", None) or ()))
        if not unseen:
            raise SystemExit(f"{args.release} saw every drive of {args.kitti_root}: give its fold models (--fold)")
        if len(datasets) > 1:  # each density's frames a part of their own: a drive calibrates once per density
            wrapper.fit_out_of_fold([(release, spaced_per_drive(ds, args.frames_per_drive, unseen)) for ds in datasets])
        else:
            wrapper.fit(spaced_per_drive(dataset, args.frames_per_drive, unseen))
    out = Path(args.out) if args.out else (Path(__file__).resolve().parents[1] / "estimators" / "pretrained"
                                           / "intervals" / f"{args.release}.json")
    wrapper.save(out, base=args.release)
    cal = wrapper.calibration_
    print(f"{out}: {len(cal['drives'])} drives, {cal['n_frames']} frames, {cal['n_pixels']} pixels, "
          f"q = {wrapper.quantile_:.3f} at {cal['coverage']}, coef {np.round(wrapper.coef_, 3).tolist()} "
          f"({time.perf_counter() - start:.0f} s)")
    return out


SIGNALS_DOC = """Which per-pixel signals rank a fold model's errors: the probe behind the shipped interval signals.

For each ``--fold DAY=MODEL`` (a fold model of ``interval_folds.sh``, trained without DAY and
a few calibration drives), the model fills two sets of frames, each occluded as
``perf/interval_lodo.py`` occludes it (rect-v1, seed 0, ``--frames-per-drive`` evenly
spaced frames per drive): its calibration drives (the other days' drives its
``training_drives_`` does not name) and DAY's drives. Every hole pixel with truth gives its
absolute error and its signals. Each variant fits a scale on the calibration pixels, ranks
each scored frame's hole pixels by it, and keeps the most confident 80 %; printed per fold is
the mean over frames of the share of hole RMSE cut (the benchmark's ``rmse_cut_80``).

Variants: ``shipped`` (border distance, depth, spread against ``scanline``; least squares
of the log error, as ``ConformalIntervalInpainter``), ``+members`` (the disagreement of an
ensemble's members, ``|m1 - m2|``, or their standard deviation beyond two), ``members for
spread``, ``+candidates`` (standard deviation of five candidate fills), ``+gradient`` (of the
fill), ``shipped, squared error`` (the same signals fitted to the squared error by a Poisson
GLM with log link: the ranking the RMSE cut rewards) and ``boosted trees`` (scikit-learn's
``HistGradientBoostingRegressor`` on every signal, log error).

    python experiments/interval_calibration.py signals --kitti-root <KITTI root> \\
        --fold 2011_09_26=<model without 2011_09_26> --fold 2011_09_30=<...> --fold 2011_10_03=<...>
"""


CANDIDATES = ("scanline", "scanline-inverse", "vertical", "vertical-inverse", "harmonic-inverse")

#: Variant name -> (signals, how the scale is fitted).
VARIANTS: dict[str, tuple[tuple[str, ...], str]] = {
    "shipped": (("border", "depth", "spread"), "log"),
    "+members": (("border", "depth", "spread", "members"), "log"),
    "members for spread": (("border", "depth", "members"), "log"),
    "+candidates": (("border", "depth", "spread", "candidates"), "log"),
    "+gradient": (("border", "depth", "spread", "gradient"), "log"),
    "shipped, squared error": (("border", "depth", "spread"), "squared"),
    "boosted trees": (("border", "depth", "spread", "members", "candidates", "gradient"), "trees"),
}

def frame_signals(x: np.ndarray, pred: np.ndarray, hole: np.ndarray, scored: np.ndarray, second: np.ndarray,
                  members: np.ndarray | None) -> dict[str, np.ndarray]:
    """Every signal of the scored pixels of one frame (each already on a log scale)."""
    from estimators.candidates import candidate_fills
    from inpaintenv.metrics import border_distance

    p = pred[scored].astype(np.float64)
    gy, gx = np.gradient(pred.astype(np.float64))
    out = {"border": np.log1p(border_distance(hole)[scored]), "depth": np.log(np.maximum(p, 1.0)),
           "spread": np.log(np.abs(p - second[scored]) + 0.1),
           "candidates": np.log(np.std(candidate_fills(x, CANDIDATES)[:, scored], axis=0) + 0.1),
           "gradient": np.log(np.hypot(gx, gy)[scored] + 0.05)}
    if members is not None:
        m = members[:, scored].astype(np.float64)
        out["members"] = np.log((np.abs(m[0] - m[1]) if len(m) == 2 else np.std(m, axis=0)) + 0.1)
    return out

def collect(model: Any, dataset: Any) -> list[dict[str, np.ndarray]]:
    """Per frame with scored hole pixels: ``error`` and every signal of those pixels."""
    from estimators.base import iter_scoring_batches
    from inpaintenv.methods.registry import make_method

    scanline = make_method("scanline")
    frames = []
    for x, gt, hole in iter_scoring_batches(dataset):
        pred = np.asarray(model.predict(x), np.float32)
        second = np.asarray(scanline.predict(x), np.float32)
        members = (np.stack([np.asarray(m.predict(x), np.float32) for m in model.estimators_], axis=1)
                   if hasattr(model, "estimators_") else None)
        for k in range(len(x)):
            scored = hole[k] & (gt[k] > 0)
            if scored.any():
                row = frame_signals(x[k], pred[k], hole[k], scored, second[k],
                                    None if members is None else members[k])
                row["error"] = np.abs(gt[k][scored].astype(np.float64) - pred[k][scored])
                frames.append(row)
    return frames

def fit_scale(frames: list[dict[str, np.ndarray]], signals: tuple[str, ...], how: str, seed: int = 0):
    """A function of one frame's signals returning a score that orders its pixels (larger = less confident)."""
    X = np.column_stack([np.concatenate([f[s] for f in frames]) for s in signals])
    r = np.concatenate([f["error"] for f in frames])
    rng = np.random.default_rng(seed)
    take = rng.choice(len(r), 200_000, replace=False) if len(r) > 200_000 else slice(None)
    X, r = X[take], r[take]
    if how == "log":
        coef, *_ = np.linalg.lstsq(np.column_stack([np.ones(len(r)), X]), np.log(r + 0.05), rcond=None)
        return lambda F: coef[0] + F @ coef[1:]
    if how == "squared":
        from sklearn.linear_model import PoissonRegressor

        glm = PoissonRegressor(alpha=0.0, max_iter=300).fit(X, r ** 2)
        return lambda F: F @ glm.coef_
    from sklearn.ensemble import HistGradientBoostingRegressor

    trees = HistGradientBoostingRegressor(max_iter=200, random_state=seed).fit(X, np.log(r + 0.05))
    return trees.predict

def keep_80_cut(frames: list[dict[str, np.ndarray]], signals: tuple[str, ...], score: Any) -> float:
    """Mean over frames of ``1 - RMSE(most confident 80 %) / RMSE(all)`` of the hole."""
    cuts = []
    for f in frames:
        e = f["error"]
        full = math.sqrt(float(np.mean(e ** 2)))
        if full == 0:
            continue
        kept = np.argsort(score(np.column_stack([f[s] for s in signals])), kind="stable")[:math.ceil(0.8 * e.size)]
        cuts.append(1.0 - math.sqrt(float(np.mean(e[kept] ** 2))) / full)
    return float(np.mean(cuts))

def signals_command(argv: list[str] | None = None) -> dict[str, dict[str, float]]:
    parser = argparse.ArgumentParser(prog="interval_calibration.py signals", description=SIGNALS_DOC, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--kitti-root", required=True)
    parser.add_argument("--fold", action="append", default=[], required=True, metavar="DAY=MODEL",
                        help="a fold model trained without recording day DAY and its calibration drives")
    parser.add_argument("--frames-per-drive", type=int, default=6, help="0 = every frame")
    parser.add_argument("--json", help="also write the cuts here")
    args = parser.parse_args(argv)

    from estimators.learned import load
    from inpaintenv.data import KittiDepth, spaced_per_drive
    from inpaintenv.files import write_json

    dataset = KittiDepth(args.kitti_root, split="train")
    drives = sorted({str(g) for g in dataset.groups})
    cuts: dict[str, dict[str, float]] = {name: {} for name in VARIANTS}
    for entry in args.fold:
        start = time.perf_counter()
        day, _, path = entry.partition("=")
        model = load(path)
        seen = set(getattr(model, "training_drives_", None) or ())
        scored = [d for d in drives if d.startswith(day) and d not in seen]
        calibration = [d for d in drives if not d.startswith(day) and d not in seen]
        if not scored or not calibration:
            raise SystemExit(f"--fold {entry}: needs drives of {day} and of other days that the model never saw "
                             f"(scored: {len(scored)}, calibration: {len(calibration)})")
        cal = collect(model, spaced_per_drive(dataset, args.frames_per_drive, calibration))
        test = collect(model, spaced_per_drive(dataset, args.frames_per_drive, scored))
        for name, (signals, how) in VARIANTS.items():
            if "members" in signals and "members" not in cal[0]:
                continue  # not an ensemble
            cuts[name][day] = keep_80_cut(test, signals, fit_scale(cal, signals, how))
        print(f"{day}: {len(calibration)} calibration / {len(scored)} scored drives, {len(test)} scored frames "
              f"({time.perf_counter() - start:.0f} s)", flush=True)
    days = [e.partition("=")[0] for e in args.fold]
    print("\n| variant | " + " | ".join(days) + " |\n|---|" + "---:|" * len(days))
    for name, row in cuts.items():
        if row:
            print(f"| {name} | " + " | ".join(f"{row[d]:.1%}" for d in days) + " |")
    cuts = {name: row for name, row in cuts.items() if row}
    if args.json:
        write_json(args.json, cuts)
    return cuts


LODO_DOC = """Which calibration protocol serves both scan tasks: leave one recording day out with fold models.

A fold model per recording day (``--fold DAY=MODEL``, trained without DAY: ``scan_lodo.py lodo
--save-folds``) fills its own day's rebuilt drives (``--frames-per-drive`` evenly spaced frames,
drive 0001 never) under ``densify-v1`` and ``rect-v1`` (``--seeds``), once; every variant is then
calibrated as ``calibrate --fold`` calibrates (out of fold, frame weighting), on the other two
days' residuals only (rect-v1 seed 0), and scored on the left-out day's. Scored pixels are each
task's, as ``evaluate --interval-coverage`` scores them: every pixel the scan did not measure
(densify-v1), the hole cut out of the scan (rect-v1, each (seed, frame) a unit). Printed per
variant, left-out day and task: mean over units of the coverage, of the mean width, and of
``rmse_cut_80`` (the share of RMSE cut by keeping the narrowest 80 %, the benchmark's ranking),
and the AUSE of the day and task in pNCNN's convention (RMSE-based, every pixel pooled, curves
normalised by their start; ranked by the interval's width).

    python experiments/interval_calibration.py lodo --kitti-root <KITTI root> --spread-method harmonic \\
        --fold 2011_09_26=<model without 2011_09_26> --fold 2011_09_30=<...> --fold 2011_10_03=<...>

``--method NAME`` scores every day with a fill that saw no drive (no fold models), and several
``--input`` kinds pool densities (calibration and each task's row; a row per kind as well): how
the sparse route's ``harmonic`` was chosen::

    python experiments/interval_calibration.py lodo --kitti-root <KITTI root> --method harmonic \\
        --spread-method nearest --input scan-rings32-v1 scan-rings16-v1 scan-rings8-v1 --frames-per-drive 3 \\
        --calibration densify-v1+rect-v1 --calibration "densify-v1+rect-v1 (+far)"

``--condition distance`` (or ``depth``, ``density``, ``frame_density``; repeatable, ``none`` the pooled
quantile) takes the quantile per bin of the distance to the nearest measurement, the predicted depth, the
measured share around the pixel or in the frame (Mondrian conformal,
``ConformalIntervalInpainter(condition=...)``; bins ``DEFAULT_EDGES``, or ``--condition-edges E1,E2,...`` for the
one condition besides none), each variant once per condition; ``--by-bin`` also prints each row's coverage per distance bin and per predicted-depth bin (pixels pooled). ``--input map`` (alone) scores a classical fill's ``rect-v1`` holes in the ground-truth maps (calibration ``rect-v1``).

``--self-check 1000,1001`` adds the condition ``self-check``: each frame's interval scaled by a factor the
frame gives itself, the ``--coverage`` quantile of the normalised residuals in probe holes (rect-v1 at those
seeds) cut into the same frame, and the quantile calibrated on residuals divided by their frame's factor.
A probe for an experiment: the holes are cut into the whole frame, not around the one being filled.
"""

#: The scan tasks scored, and the calibrations compared: (protocol, signals).
SCAN_TASKS = ("densify-v1", "rect-v1")
SHIPPED_SIGNALS = ("border", "depth", "spread")
LODO_SIGNALS = SHIPPED_SIGNALS + ("far",)
#: Every signal collected per pixel: the variants' and the measured share a quantile may be conditioned on.
FEATURE_SIGNALS = LODO_SIGNALS + ("density", "frame_density")
CALIBRATIONS = (("densify-v1", SHIPPED_SIGNALS), ("rect-v1", SHIPPED_SIGNALS),
                ("densify-v1+rect-v1", SHIPPED_SIGNALS), ("densify-v1+rect-v1", LODO_SIGNALS))


def variant_name(protocol: str, signals: tuple[str, ...]) -> str:
    """A compared calibration's name: its protocol, ``" (+far)"`` with the signal ``far``."""
    return protocol + ("" if signals == SHIPPED_SIGNALS else " (+far)")


def day_residuals(model: Any, frames: Any, spread: Any, seeds: tuple[int, ...], tasks: tuple[str, ...] = SCAN_TASKS) -> dict:
    """``(task, seed) -> (design matrix, residuals, frame)`` of ``model`` on ``frames`` (``tasks``)."""
    from estimators.intervals import scored_residuals

    pairs = ([("densify-v1", 0)] if "densify-v1" in tasks else []) + [("rect-v1", seed) for seed in seeds]
    return {(t, seed): scored_residuals(model, frames, FEATURE_SIGNALS, spread, t, seed) for t, seed in pairs}


def self_checked(coef: np.ndarray, normed: np.ndarray, frame: np.ndarray, days: dict, probes: dict, keys: list,
                 coverage: float) -> tuple[dict, np.ndarray]:
    """``--self-check``: each (day, kind)'s frame factors, and the quantile of the calibration's normalised
    residuals (rows of ``keys``' parts, pooled) divided by their frame's factor."""
    from estimators.intervals import residual_quantiles

    factor = {(d, k): frame_factors(coef, probes[d][k], coverage) for d in probes for k in probes[d]}
    cal_factor = np.concatenate([factor[d, k](days[d][k][(t, 0)][2]) for d, k, t in keys])
    return factor, residual_quantiles(normed / cal_factor, frame, "frame", coverage)[1]


def print_by_bin(rows: list[dict[str, Any]]) -> None:
    """``--by-bin``: each row's coverage per bin of every variable of ``DEFAULT_EDGES``, pixels pooled."""
    from inpaintenv.values.interval_calibration import DEFAULT_EDGES

    for variable in DEFAULT_EDGES:
        unit = {"distance": "px to the nearest measurement", "depth": "predicted depth, m"}.get(variable, "measured share")
        labels = bin_labels(DEFAULT_EDGES[variable])
        print(f"\ncoverage by {variable} bin ({unit}), pixels pooled: coverage (pixels)\n| calibrated on | condition | "
              "day | task | input | " + " | ".join(labels) + " |\n|---|---|---|---|---|" + "---:|" * len(labels))
        for row in rows:
            cells = " | ".join("–" if c is None else f"{c:.3f} ({k})" for c, k in row[f"by_{variable}"])
            print(f"| {row['calibration']} | {row['condition']} | {row['day']} | {row['task']} | {row['input']} | "
                  f"{cells} |")


def lodo_command(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(prog="interval_calibration.py lodo", description=LODO_DOC,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--kitti-root", required=True)
    parser.add_argument("--fold", action="append", default=[], metavar="DAY=MODEL")
    parser.add_argument("--method", help="a fill that saw no drive, scoring every day (instead of --fold)")
    parser.add_argument("--input", nargs="+", default=["scan"], choices=[k for k in INPUT_KINDS if INPUTS[k].separate] + ["map"],
                        help="scan kinds, pooled (densities); or map alone (rect-v1 holes in the ground-truth map)")
    parser.add_argument("--frames-per-drive", type=int, default=8, help="0 = every frame")
    parser.add_argument("--seeds", default="0,1,2", help="rect-v1 seeds scored, comma-separated")
    parser.add_argument("--spread-method", default="harmonic")
    parser.add_argument("--coverage", type=float, default=0.9)
    parser.add_argument("--calibration", action="append", choices=[variant_name(*c) for c in CALIBRATIONS],
                        help="the variants compared (repeatable; default every one)")
    parser.add_argument("--condition", action="append", choices=["none", *CONDITIONS],
                        help="quantile per bin of this variable (repeatable; default none: one pooled quantile)")
    parser.add_argument("--condition-edges", type=edges_option, metavar="E1,E2,...",
                        help="the bins' edges of the one --condition other than none (default DEFAULT_EDGES)")
    parser.add_argument("--by-bin", action="store_true", help="also print coverage per distance and depth bin")
    parser.add_argument("--self-check", metavar="SEEDS", type=seeds_option, help="rect-v1 seeds of the probe holes of the condition "
                        "self-check (comma-separated): a per-frame factor from the frame's own probe residuals")
    parser.add_argument("--json", help="also write the rows here")
    args = parser.parse_args(argv)
    conditions = args.condition or ["none"]
    if args.condition_edges and len(set(conditions) - {"none"}) != 1:
        raise SystemExit(f"--condition-edges: the bin edges of one --condition other than none, got {conditions}")
    maps, tasks = "map" in args.input, (("rect-v1",) if "map" in args.input else SCAN_TASKS)
    if maps and (len(args.input) > 1 or (args.calibration and args.calibration != ["rect-v1"])):
        raise SystemExit("--input map: alone, with --calibration rect-v1 (a map has one task, its rect-v1 holes)")
    if bool(args.fold) == bool(args.method):
        raise SystemExit("give a --fold DAY=MODEL per day, or --method (a fill that saw no drive), not both")

    from estimators.intervals import balanced_scale, cell_of, cell_quantiles, fit_condition, residual_quantiles, scale_from
    from inpaintenv.values.interval_calibration import DEFAULT_EDGES
    from estimators.learned import load
    from inpaintenv.data import KittiDepth, spaced_per_drive
    from inpaintenv.methods.registry import make_method

    datasets = {kind: KittiDepth(args.kitti_root, split="train", input=kind) for kind in args.input}
    drives = sorted({str(g) for g in datasets[args.input[0]].groups} - {OFFICIAL_DRIVE})
    seeds = tuple(int(s) for s in args.seeds.split(","))
    spread = make_method(args.spread_method)
    entries = [e.partition("=")[::2] for e in args.fold] or [(day, "") for day in sorted({d[:10] for d in drives})]
    probe_seeds = args.self_check or ()
    if probe_seeds:
        conditions.append("self-check")
    days: dict[str, dict] = {}  # day -> input kind -> (task, seed) -> residuals
    probes: dict[str, dict] = {}  # day -> input kind -> (rect-v1, probe seed) -> residuals
    for day, path in entries:
        start = time.perf_counter()
        model = load(path) if path else make_method(args.method)
        mine = [d for d in drives if d.startswith(day)]
        frames = {kind: spaced_per_drive(ds, args.frames_per_drive, mine) for kind, ds in datasets.items()}
        days[day] = {kind: day_residuals(model, f, spread, seeds, tasks) for kind, f in frames.items()}
        probes[day] = {kind: day_residuals(model, f, spread, probe_seeds, ("rect-v1",)) for kind, f in frames.items()}
        print(f"{day}: {len(mine)} drives x {len(datasets)} inputs ({time.perf_counter() - start:.0f} s)", flush=True)
    rows, every = [], "+".join(args.input)
    print("| calibrated on | condition | left-out day | task | input | coverage | mean width (m) | keep-80 % cut | "
          "AUSE (pooled) |\n|---|---|---|---|---|---:|---:|---:|---:|")
    for protocol, signals in CALIBRATIONS:
        variant = variant_name(protocol, signals)
        if (args.calibration and variant not in args.calibration) or (maps and variant != "rect-v1"):
            continue
        cols = [0] + [1 + FEATURE_SIGNALS.index(name) for name in signals]
        for day in days:
            keys = [(d, k, t) for d in days if d != day for k in args.input for t in protocol.split("+")]
            cal = pooled([days[d][k][(t, 0)] for d, k, t in keys])
            coef = np.zeros(1 + len(FEATURE_SIGNALS))  # the signals left out weigh 0
            coef[cols] = balanced_scale(cal[0][:, cols], cal[1], cal[2], signals, 0, 200_000, "frame", args.coverage)
            normed = cal[1] / scale_from(coef, cal[0])
            _, q = residual_quantiles(normed, cal[2], "frame", args.coverage)
            if probe_seeds:
                factor, q_checked = self_checked(coef, normed, cal[2], days, probes, keys, args.coverage)
            for cond in conditions:
                found = None if cond in ("none", "self-check") else fit_condition(cond, args.condition_edges or DEFAULT_EDGES[cond], FEATURE_SIGNALS, cal[0], normed,
                                                                   cal[2], "frame", args.coverage)
                for task in tasks:
                    for kinds in [args.input] + ([[k] for k in args.input] if len(args.input) > 1 else []):
                        parts = [(k, v) for k in kinds for (t, _), v in days[day][k].items() if t == task]
                        test = pooled([v for _, v in parts])
                        if cond == "self-check":
                            qq = q_checked * np.concatenate([factor[day, k](v[2]) for k, v in parts])
                        else:
                            qq = q if found is None else cell_quantiles(found, q, args.coverage, True, "frame")[
                                cell_of(found, FEATURE_SIGNALS, test[0])]
                        name = every if len(kinds) > 1 else kinds[0]
                        row = {"calibration": variant, "condition": cond, "day": day, "task": task, "input": name,
                               **interval_scores(coef, qq, *test), **coverage_by_bin(coef, qq, test[0], test[1], FEATURE_SIGNALS)}
                        rows.append(row)
                        print(f"| {variant} | {cond} | {day} | {task} | {name} | {row['coverage']:.3f} | "
                              f"{row['width']:.2f} | {row['cut_80']:.1%} | {row['ause']:.3f} |", flush=True)
    if args.by_bin:
        print_by_bin(rows)
    if args.json:
        from inpaintenv.files import write_json
        write_json(args.json, rows)
    return {"rows": rows}


COMMANDS = {"calibrate": calibrate_command, "signals": signals_command, "lodo": lodo_command}


def main(argv: list[str] | None = None) -> Any:
    """Run the command named by ``argv[0]`` (see the module docstring)."""
    return run_command("interval_calibration.py", COMMANDS, argv)


if __name__ == "__main__":
    sys.exit(exit_status(main()))
