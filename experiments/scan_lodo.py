"""A learned fill of a single LiDAR scan against the classical fills, leaving one recording day out.

The sets of issue 52: each recording day's drives without drive 0001 (2011_09_26,
2011_09_30, 2011_10_03), the official drive 0001 frames that have a scan, and KITTI's
val_selection_cropped; every frame a 352x1216 bottom-centre crop. Two tasks: ``densify``
(the whole scan in, scored on the ground-truth pixels it did not measure) and ``rect``
(rect-v1's rectangles cut out of the scan, scored in the hole, seed 0). A learned
``BlendInpainter`` (``--recipe`` as JSON) is trained on the two other days' frames and
scored on the left-out day (and, for 2011_09_26, on the two official sets). Ratios are of
mean-over-frames RMSE, with a paired 95 % bootstrap interval over frames; times are
``predict`` per frame beside ``harmonic``'s in the same run.

    python experiments/scan_lodo.py --classical-only          # the classical table
    python experiments/scan_lodo.py --recipe '{"candidates": ["harmonic", "ipbasic", "nearest"]}'
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from inpaintenv.data import KittiDepth
from inpaintenv.data.base import ConcatDataset, Subset, spaced_per_drive
from inpaintenv.data.inputs import method_input
from inpaintenv.masks import get_protocol
from inpaintenv.methods.registry import make_method

from _common import default_root

DAYS = ("2011_09_26", "2011_09_30", "2011_10_03")
OFFICIAL = "2011_09_26_drive_0001_sync"
CROP = (352, 1216)
CLASSICAL = ("harmonic", "harmonic-inverse", "ipbasic", "nearest", "scanline")


def day_sets(root: str, per_drive: int) -> dict[str, object]:
    """Each day's drives (official drive 0001 apart), the official drive 0001 and val_selection."""
    train = KittiDepth(root, split="train", input="scan", crop=CROP)
    groups = np.asarray(train.groups)
    out: dict[str, object] = {}
    for day in DAYS:
        drives = sorted({g for g in groups if g.startswith(day) and g != OFFICIAL})
        out[day] = spaced_per_drive(Subset(train, [i for i, g in enumerate(groups) if g in drives]), per_drive)
    out["official-0001"] = Subset(train, [i for i, g in enumerate(groups) if g == OFFICIAL])
    out["val-selection"] = KittiDepth(root, split="val_selection", camera="both", input="scan")
    return out


def scores(method, frames, task: str) -> tuple[np.ndarray, float]:
    """Per-frame RMSE (NaN where nothing is scored) and ms per frame of ``predict``."""
    rect = get_protocol("rect-v1")
    errs, seconds = [], 0.0
    for i in range(len(frames)):
        scan, gt = (a[0] for a in frames.load_pairs([i]))
        hole = rect.mask(scan.shape, 0, i) if task == "rect" else np.zeros(scan.shape, bool)
        x = method_input(scan, hole, "scan")
        start = time.perf_counter()
        pred = method.predict(x)
        seconds += time.perf_counter() - start
        scored = (gt > 0) & (hole if task == "rect" else np.isnan(x))
        errs.append(np.sqrt(np.mean((pred[scored] - gt[scored]) ** 2)) if scored.any() else np.nan)
    return np.asarray(errs), 1000.0 * seconds / max(len(frames), 1)


def paired_ratio(a: np.ndarray, b: np.ndarray, n_boot: int = 2000) -> tuple[float, float, float]:
    """mean(a) / mean(b) over frames scored by both, and its paired 95 % bootstrap interval."""
    ok = np.isfinite(a) & np.isfinite(b)
    a, b = a[ok], b[ok]
    rng = np.random.default_rng(0)
    idx = rng.integers(0, len(a), (n_boot, len(a)))
    boot = a[idx].mean(1) / b[idx].mean(1)
    return float(a.mean() / b.mean()), float(np.quantile(boot, 0.025)), float(np.quantile(boot, 0.975))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--per-drive", type=int, default=8, help="evenly spaced frames per drive (0: all)")
    parser.add_argument("--recipe", default="{}", help="BlendInpainter keywords as JSON")
    parser.add_argument("--days", default=",".join(DAYS), help="the days to leave out, comma-separated")
    parser.add_argument("--classical-only", action="store_true")
    args = parser.parse_args()
    root = default_root()
    if root is None:
        parser.error("set INPAINTENV_KITTI_ROOT to the KITTI slice")
    sets = day_sets(str(root), args.per_drive)
    if args.classical_only:
        for name, frames in sets.items():
            for task in ("densify", "rect"):
                for method in CLASSICAL:
                    e, ms = scores(make_method(method), frames, task)
                    print(f"{name:14s} {task:8s} {method:17s} rmse {np.nanmean(e):.3f} m  {ms:.0f} ms/frame", flush=True)
        return
    from estimators.learned import BlendInpainter

    for day in args.days.split(","):
        train = ConcatDataset([sets[d] for d in DAYS if d != day])
        start = time.perf_counter()
        est = BlendInpainter(**json.loads(args.recipe)).fit(train)
        fit_s = time.perf_counter() - start
        for name in [day] + (["official-0001", "val-selection"] if day == DAYS[0] else []):
            for task in ("densify", "rect"):
                ours, ms = scores(est, sets[name], task)
                base, base_ms = scores(make_method("harmonic"), sets[name], task)
                r, lo, hi = paired_ratio(ours, base)
                print(f"left out {day} (fit {fit_s:.0f} s) | {name:14s} {task:8s} model {np.nanmean(ours):.3f} m, "
                      f"harmonic {np.nanmean(base):.3f} m, ratio {r:.3f} [{lo:.3f}, {hi:.3f}] | "
                      f"{ms:.0f} vs {base_ms:.0f} ms/frame", flush=True)


if __name__ == "__main__":
    main()
