"""A learned fill of a single LiDAR scan against the classical fills, leaving one recording day out.

The sets of issue 52: each recording day's drives without drive 0001 (2011_09_26,
2011_09_30, 2011_10_03), the official drive 0001 frames that have a scan (both cameras), and
KITTI's val_selection_cropped; every frame a 352x1216 bottom-centre crop. Two tasks:
``densify`` (the whole scan in, scored on the ground-truth pixels it did not measure) and
``rect`` (rect-v1's rectangles cut out of the scan, scored in the hole; ``--seeds``, each
(seed, frame) one unit). A learned estimator (``--estimator``, keywords ``--recipe`` as JSON)
is trained on the two other days' frames and scored on the left-out day (and, for
2011_09_26, on the two official sets). Ratios are of mean-over-units RMSE to the strongest
classical fill of that set and task, with a paired 95 % bootstrap interval over units; times
are ``predict`` per frame beside ``harmonic``'s in the same run.

    python experiments/scan_lodo.py classical                      # the classical table
    python experiments/scan_lodo.py lodo --recipe '{"near_distance": 8}'   # ScanBlendInpainter
    python experiments/scan_lodo.py release --save /tmp/kitti-scan-v1      # all rebuilt drives
    python experiments/scan_lodo.py official --method kitti-scan-v1        # a method on the official sets
    python experiments/scan_lodo.py time --method kitti-scan-v1            # its ms/frame beside harmonic's
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np

from inpaintenv.data import KittiDepth
from inpaintenv.data.base import ConcatDataset, Subset, spaced_per_drive
from inpaintenv.data.inputs import method_input
from inpaintenv.files.jsonio import loads_json
from inpaintenv.masks import get_protocol
from inpaintenv.methods.registry import make_method

from _common import default_root, run_command

DAYS = ("2011_09_26", "2011_09_30", "2011_10_03")
OFFICIAL = "2011_09_26_drive_0001_sync"
OFFICIAL_SETS = ("official-0001", "val-selection")
CROP = (352, 1216)
#: Every classical fill the learned one is compared with; the strongest of a set and task is the bar.
CLASSICAL = ("harmonic", "harmonic-inverse", "ipbasic", "ipbasic-scan", "nearest", "scanline", "harmonic-ipbasic")
TASKS = ("densify", "rect")


def day_sets(root: str, per_drive: int) -> dict[str, Any]:
    """Each day's drives (official drive 0001 apart), the official drive 0001 (both cameras) and val_selection."""
    train = KittiDepth(root, split="train", input="scan", crop=CROP)
    groups = np.asarray(train.groups)
    out: dict[str, Any] = {}
    for day in DAYS:
        drives = sorted({g for g in groups if g.startswith(day) and g != OFFICIAL})
        out[day] = spaced_per_drive(Subset(train, [i for i, g in enumerate(groups) if g in drives]), per_drive)
    out["official-0001"] = KittiDepth(root, split="train", camera="both", input="scan", crop=CROP, drives=[OFFICIAL])
    out["val-selection"] = KittiDepth(root, split="val_selection", camera="both", input="scan")
    return out


def scores(method: Any, frames: Any, task: str, seeds: tuple[int, ...] = (0,)) -> tuple[np.ndarray, float]:
    """Per-unit RMSE (NaN where nothing is scored; a unit is a frame, for ``rect`` a (seed, frame))
    and ms per frame of ``predict``."""
    rect = get_protocol("rect-v1")
    errs, seconds, calls = [], 0.0, 0
    for i in range(len(frames)):
        scan, gt = (a[0] for a in frames.load_pairs([i]))
        for seed in seeds if task == "rect" else (0,):
            hole = rect.mask(scan.shape, seed, i) if task == "rect" else np.zeros(scan.shape, bool)
            x = method_input(scan, hole, "scan")
            start = time.perf_counter()
            pred = method.predict(x)
            seconds, calls = seconds + time.perf_counter() - start, calls + 1
            scored = (gt > 0) & (hole if task == "rect" else np.isnan(x))
            errs.append(np.sqrt(np.mean((pred[scored] - gt[scored]) ** 2)) if scored.any() else np.nan)
    return np.asarray(errs), 1000.0 * seconds / max(calls, 1)


def paired_ratio(a: np.ndarray, b: np.ndarray, n_boot: int = 2000) -> tuple[float, float, float]:
    """mean(a) / mean(b) over units scored by both, and its paired 95 % bootstrap interval."""
    ok = np.isfinite(a) & np.isfinite(b)
    a, b = a[ok], b[ok]
    rng = np.random.default_rng(0)
    idx = rng.integers(0, len(a), (n_boot, len(a)))
    boot = a[idx].mean(1) / b[idx].mean(1)
    return float(a.mean() / b.mean()), float(np.quantile(boot, 0.025)), float(np.quantile(boot, 0.975))


def compare(label: str, method: Any, name: str, frames: Any, seeds: tuple[int, ...]) -> None:
    """One line per task: ``method`` against the strongest classical fill of ``frames``, ms beside harmonic's."""
    for task in TASKS:
        ours, ms = scores(method, frames, task, seeds)
        classical = {m: scores(make_method(m), frames, task, seeds) for m in CLASSICAL}
        best = min(classical, key=lambda m: np.nanmean(classical[m][0]))
        r, lo, hi = paired_ratio(ours, classical[best][0])
        print(f"{label} | {name:14s} {task:8s} ours {np.nanmean(ours):.3f} m, {best} {np.nanmean(classical[best][0]):.3f}"
              f" m, ratio {r:.3f} [{lo:.3f}, {hi:.3f}] | {ms:.0f} vs harmonic {classical['harmonic'][1]:.0f} ms/frame",
              flush=True)


def estimator(args: argparse.Namespace) -> Any:
    """A fresh estimator of ``--estimator`` with ``--recipe``'s keywords."""
    import estimators.learned as learned

    return getattr(learned, args.estimator)(**loads_json(args.recipe, "--recipe", allow_nan=False))


def _parser(description: str, learned: bool) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--per-drive", type=int, default=8, help="evenly spaced frames per drive (0: all)")
    parser.add_argument("--seeds", default="0,1,2", help="rect-v1 seeds, comma-separated")
    if learned:
        parser.add_argument("--estimator", default="ScanBlendInpainter", help="a class of estimators.learned")
        parser.add_argument("--recipe", default="{}", help="its keywords as JSON")
    return parser


def _sets(parser: argparse.ArgumentParser, args: argparse.Namespace) -> dict[str, Any]:
    root = default_root()
    if root is None:
        parser.error("set INPAINTENV_KITTI_ROOT to the KITTI slice")
    return day_sets(str(root), args.per_drive)


def _seeds(args: argparse.Namespace) -> tuple[int, ...]:
    return tuple(int(s) for s in args.seeds.split(","))


def cmd_classical(argv: list[str]) -> None:
    """Every classical fill's mean RMSE and ms/frame on every set and task."""
    parser = _parser("the classical fills on every set and task", learned=False)
    args = parser.parse_args(argv)
    for name, frames in _sets(parser, args).items():
        for task in TASKS:
            for method in CLASSICAL:
                e, ms = scores(make_method(method), frames, task, _seeds(args))
                print(f"{name:14s} {task:8s} {method:17s} rmse {np.nanmean(e):.3f} m  {ms:.0f} ms/frame", flush=True)


def cmd_lodo(argv: list[str]) -> None:
    """Train on two days, score on the third (and on the official sets when 2011_09_26 is left out)."""
    parser = _parser("leave one recording day out", learned=True)
    parser.add_argument("--days", default=",".join(DAYS), help="the days to leave out, comma-separated")
    parser.add_argument("--save-folds", help="folder to save each fold model in (as <folder>/<day>)")
    args = parser.parse_args(argv)
    sets = _sets(parser, args)
    for day in args.days.split(","):
        start = time.perf_counter()
        est = estimator(args).fit(ConcatDataset([sets[d] for d in DAYS if d != day]))
        label = f"left out {day} (fit {time.perf_counter() - start:.0f} s)"
        if args.save_folds:
            est.save(f"{args.save_folds}/{day}")
        for name in [day] + (list(OFFICIAL_SETS) if day == DAYS[0] else []):
            compare(label, est, name, sets[name], _seeds(args))


def cmd_release(argv: list[str]) -> None:
    """Train on every rebuilt drive of the three days (never drive 0001 or val) and save to ``--save``."""
    parser = _parser("train on all rebuilt drives and save", learned=True)
    parser.add_argument("--save", required=True, help="folder to save the fitted estimator in")
    args = parser.parse_args(argv)
    sets = _sets(parser, args)
    start = time.perf_counter()
    est = estimator(args).fit(ConcatDataset([sets[d] for d in DAYS]))
    print(f"fit {time.perf_counter() - start:.0f} s on {est.training_frames_} frames; saved {est.save(args.save)}")


def cmd_official(argv: list[str]) -> None:
    """A registered method (a release, ``pretrained``, a classical fill) on the two official sets."""
    parser = _parser("a method on the official sets", learned=False)
    parser.add_argument("--method", required=True, help="a registered method name")
    args = parser.parse_args(argv)
    sets = _sets(parser, args)
    for name in OFFICIAL_SETS:
        compare(args.method, make_method(args.method), name, sets[name], _seeds(args))


def cmd_time(argv: list[str]) -> None:
    """ms/frame of ``--method`` and of harmonic, interleaved frame by frame (the median of
    ``--repeats`` calls each), on val_selection: on a shared machine the ratio holds better than
    either time."""
    parser = _parser("predict time beside harmonic's, interleaved", learned=False)
    parser.add_argument("--method", required=True, help="a registered method name")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    frames = _sets(parser, args)["val-selection"]
    methods = {name: make_method(name) for name in (args.method, "harmonic")}
    times: dict[str, list[float]] = {name: [] for name in methods}
    rect = get_protocol("rect-v1")
    for i in range(len(frames)):
        scan = frames.load_pairs([i])[0][0]
        for task in TASKS:
            hole = rect.mask(scan.shape, 0, i) if task == "rect" else np.zeros(scan.shape, bool)
            x = method_input(scan, hole, "scan")
            for name, method in methods.items():
                method.predict(x)  # warm-up
                calls = []
                for _ in range(args.repeats):
                    start = time.perf_counter()
                    method.predict(x)
                    calls.append(time.perf_counter() - start)
                times[name].append(1000.0 * float(np.median(calls)))
    ours, base = np.asarray(times[args.method]), np.asarray(times["harmonic"])
    for task, pick in zip(TASKS, (slice(0, None, 2), slice(1, None, 2))):
        print(f"{args.method} {task}: {ours[pick].mean():.0f} vs harmonic {base[pick].mean():.0f} ms/frame, "
              f"ratio {ours[pick].mean() / base[pick].mean():.2f}")


COMMANDS = {"classical": cmd_classical, "lodo": cmd_lodo, "release": cmd_release, "official": cmd_official,
            "time": cmd_time}

if __name__ == "__main__":
    run_command("scan_lodo.py", COMMANDS, None)
