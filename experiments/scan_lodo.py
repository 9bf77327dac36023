"""A learned fill of a single LiDAR scan against the classical fills, leaving one recording day out.

The sets: each recording day's drives without drive 0001 (2011_09_26,
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
    python experiments/scan_lodo.py density --method pretrained            # per density, every set
    python experiments/scan_lodo.py holes --per-drive 2 --seeds 0,1        # default vs the map release in holes
    python experiments/scan_lodo.py lodo --estimator mlp --inputs scan-rings16-v1,scan-rings8-v1 \
        --per-drive 3 --densities "32 beams,16 beams,8 beams"              # a learned correction per density

``density``'s densities: the scan as it is (64 beams), every 2nd / 4th / 8th laser ring (32, 16, 8
beams; rings from the day's calibration), a seeded 50 / 25 / 10 % of its points, rect-v1's holes in
the 64-beam scan. ``holes``: the default and the map release (fed the holed scan) in those holes,
and the map release beyond D px of every measurement (D chosen with one day left out).
"""

from __future__ import annotations

import argparse
import copy
import time
from typing import Any

import cv2
import numpy as np

from inpaintenv.data import KittiDepth
from inpaintenv.data.base import ConcatDataset, Subset, spaced_per_drive
from inpaintenv.data.calibration import Calibration, read_calibration
from inpaintenv.data.thinning import thin_scan_by_points, thin_scan_by_rings
from inpaintenv.data.inputs import method_input
from inpaintenv.files.jsonio import loads_json, write_json
from inpaintenv.exceptions import InvalidInputError
from inpaintenv.masks import get_protocol
from inpaintenv.methods.registry import make_method

from _common import PROBE_FILLS, ResidualProbe, default_root, numbers_option, run_command

DAYS = ("2011_09_26", "2011_09_30", "2011_10_03")
OFFICIAL = "2011_09_26_drive_0001_sync"
OFFICIAL_SETS = ("official-0001", "val-selection")
CROP = (352, 1216)
#: Every classical fill the learned one is compared with; the strongest of a set and task is the bar.
CLASSICAL = ("harmonic", "harmonic-inverse", "ipbasic", "ipbasic-scan", "nearest", "scanline", "harmonic-ipbasic")
TASKS = ("densify", "rect")
def day_sets(root: str, per_drive: int, kind: str = "scan") -> dict[str, Any]:
    """Each day's drives (official drive 0001 apart), the official drive 0001 (both cameras) and val_selection,
    their scans at the input kind ``kind``."""
    train = KittiDepth(root, split="train", input=kind, crop=CROP)
    groups = np.asarray(train.groups)
    out: dict[str, Any] = {}
    for day in DAYS:
        drives = sorted({g for g in groups if g.startswith(day) and g != OFFICIAL})
        out[day] = spaced_per_drive(Subset(train, [i for i, g in enumerate(groups) if g in drives]), per_drive)
    out["official-0001"] = KittiDepth(root, split="train", camera="both", input=kind, crop=CROP, drives=[OFFICIAL])
    out["val-selection"] = KittiDepth(root, split="val_selection", camera="both", input=kind)
    return out


def paired_ratio(a: np.ndarray, b: np.ndarray, n_boot: int = 2000) -> tuple[float, float, float]:
    """mean(a) / mean(b) over units scored by both, and its paired 95 % bootstrap interval."""
    ok = np.isfinite(a) & np.isfinite(b)
    a, b = a[ok], b[ok]
    rng = np.random.default_rng(0)
    idx = rng.integers(0, len(a), (n_boot, len(a)))
    boot = a[idx].mean(1) / b[idx].mean(1)
    return float(a.mean() / b.mean()), float(np.quantile(boot, 0.025)), float(np.quantile(boot, 0.975))


def estimator(args: argparse.Namespace) -> Any:
    """A fresh estimator of ``--estimator`` with ``--recipe``'s keywords."""
    import estimators.learned as learned

    return getattr(learned, args.estimator)(**loads_json(args.recipe, "--recipe", allow_nan=False))


def _parser(description: str, learned: bool) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--per-drive", type=int, default=8, help="evenly spaced frames per drive (0: all)")
    parser.add_argument("--seeds", default="0,1,2", help="rect-v1 seeds, comma-separated")
    if learned:
        parser.add_argument("--estimator", default="ScanBlendInpainter", help="a class of estimators.learned, or "
                            "mlp (ResidualProbe)")
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
    methods = {m: make_method(m) for m in CLASSICAL}
    for name, frames in _sets(parser, args).items():
        density_table(name, frames, methods, "harmonic", ("64 beams", "rect-v1 hole"), _seeds(args), every=True)


def cmd_lodo(argv: list[str]) -> None:
    """Train on two days, score on the third (and on the official sets when 2011_09_26 is left out).

    ``--inputs``: train on the scans at those input kinds (``scan-rings16-v1``, ...); ``--densities``: score
    those (``density``'s table; by default the 64-beam scan, ``densify``, and rect-v1's holes in it, ``rect``)."""
    parser = _parser("leave one recording day out", learned=True)
    parser.add_argument("--days", default=",".join(DAYS), help="the days to leave out, comma-separated")
    parser.add_argument("--save-folds", help="folder to save each fold model in (as <folder>/<day>)")
    parser.add_argument("--shrinks", type=numbers_option, help="score copies of each fold model at these shrinks (comma-separated; "
                        "a parameter of the estimator, e.g. SparseResidualInpainter's), each its own row")
    parser.add_argument("--inputs", default="scan", help="the input kinds trained on, comma-separated")
    parser.add_argument("--also", default="", help="registered methods scored as rows beside ours (e.g. "
                        "kitti-ensemble-v1; releases saw every day), comma-separated")
    parser.add_argument("--densities", default="64 beams,rect-v1 hole",
                        help=f"the densities scored (of: {_LABELS_HELP})")
    args = parser.parse_args(argv)
    if (args.save_folds or args.shrinks) and args.estimator == "mlp":
        parser.error("--save-folds, --shrinks: not for a probe")
    try:  # a shrink the estimator refuses is refused now, not after the first fit
        for copy_at in shrunk(estimator(args), args.shrinks or ()).values():
            copy_at._check_params()
    except InvalidInputError as err:
        parser.error(f"argument --shrinks: {err}")
    densities = tuple(args.densities.split(","))
    sets = _sets(parser, args)
    train = {kind: sets if kind == "scan" else day_sets(str(default_root()), args.per_drive, kind)
             for kind in args.inputs.split(",")}
    for day in args.days.split(","):
        start = time.perf_counter()
        frames = [t[d] for t in train.values() for d in DAYS if d != day]
        est = ResidualProbe(**loads_json(args.recipe, "--recipe")).fit(frames) if args.estimator == "mlp" \
            else estimator(args).fit(ConcatDataset(frames))
        label = f"left out {day} (fit {time.perf_counter() - start:.0f} s)"
        if args.save_folds:
            est.save(f"{args.save_folds}/{day}")
        ours = shrunk(est, args.shrinks) if args.shrinks else {"ours": est}
        also = {m: make_method(m) for m in args.also.split(",") if m}
        methods = {**ours, **also, **{m: make_method(m) for m in CLASSICAL}}
        for name in [day] + (list(OFFICIAL_SETS) if day == DAYS[0] else []):
            density_table(name, sets[name], methods, (*ours, *also), densities, _seeds(args), f"{label} | ")


def shrunk(est: Any, shrinks: tuple[float, ...]) -> dict[str, Any]:
    """``ours shrink S`` -> a copy of the fitted ``est`` (weights shared) with ``shrink=S``, per S of ``shrinks``."""
    return {f"ours shrink {s:g}": copy.copy(est).set_params(shrink=float(s)) for s in shrinks}


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
    methods = {args.method: make_method(args.method), **{m: make_method(m) for m in CLASSICAL}}
    for name in OFFICIAL_SETS:
        density_table(name, sets[name], methods, args.method, ("64 beams", "rect-v1 hole"), _seeds(args))


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


#: Each density: (label, kept rings 1 in k, or kept share of points).
DENSITIES = (("64 beams", 1, None), ("32 beams", 2, None), ("16 beams", 4, None), ("8 beams", 8, None),
             ("50 % points", None, 0.5), ("25 % points", None, 0.25), ("10 % points", None, 0.1))
#: rect-v1's holes cut into the scan at a density (label -> the density's label), scored in the hole.
HOLE_LABELS = {"rect-v1 hole": "64 beams", "16 beams + rect-v1 hole": "16 beams", "8 beams + rect-v1 hole": "8 beams"}
DENSITY_LABELS = tuple(d[0] for d in DENSITIES) + tuple(HOLE_LABELS)  # what density and lodo --densities score
#: The labels for an argparse help string, which %-formats it ("50 % points" would crash ``--help``).
_LABELS_HELP = ", ".join(DENSITY_LABELS).replace("%", "%%")
#: Raw image size (W, H) of each recording day; frames are its bottom-centre CROP.
RAW_SIZES = {"2011_09_26": (1242, 375), "2011_09_30": (1226, 370), "2011_10_03": (1241, 376)}


def crop_calibration(root: str, day: str, camera: int) -> Calibration:
    """The day's projection into camera ``camera``, shifted to the bottom-centre CROP its frames are scored in."""
    width, height = RAW_SIZES[day]
    calib = read_calibration(f"{root}/calib/{day}", size=(width, height), camera=camera)
    shift = np.array([[1.0, 0.0, -((width - CROP[1]) // 2)], [0.0, 1.0, -(height - CROP[0])], [0.0, 0.0, 1.0]])
    return Calibration(shift @ calib.matrix, (CROP[1], CROP[0]), calib.kind, calib.source, calib.camera)


def thinned(scan: np.ndarray, density: tuple[str, int | None, float | None], calibration: Calibration,
            seed: int) -> np.ndarray:
    """``scan`` at ``density`` (an item of :data:`DENSITIES`)."""
    _, every, share = density
    if share is not None:
        return thin_scan_by_points(scan, share, seed)
    return scan if every == 1 else thin_scan_by_rings(scan, calibration, every)


def density_units(root: str, frames: Any, seeds: tuple[int, ...], densities: tuple[str, ...]) -> Any:
    """Every unit of every density of ``frames``: ``(density label, method input, ground truth, scored pixels)``.

    A unit is a frame at each density (scored on the ground-truth pixels it did not measure), and a
    (seed, frame) for rect-v1's holes cut into the scan at a density (:data:`HOLE_LABELS`; scored in the
    hole); only the ``densities`` named."""
    rect, calibrations = get_protocol("rect-v1"), {}
    for i in range(len(frames)):
        scan, gt = (a[0] for a in frames.load_pairs([i]))
        drive, camera = frames.frame_ids[i].split("/")[:2]
        key = (drive[:10], int(camera[-1]))
        if key not in calibrations:
            calibrations[key] = crop_calibration(root, *key)
        for density in (d for d in DENSITIES if d[0] in densities):
            x = method_input(thinned(scan, density, calibrations[key], i), np.zeros(scan.shape, bool), "scan")
            yield density[0], x, gt, (gt > 0) & np.isnan(x)
        for label in (h for h in HOLE_LABELS if h in densities):
            density, = (d for d in DENSITIES if d[0] == HOLE_LABELS[label])
            base = thinned(scan, density, calibrations[key], i)
            for seed in seeds:
                hole = rect.mask(scan.shape, seed, i)
                yield label, method_input(base, hole, "scan"), gt, (gt > 0) & hole


def column_regions(x: np.ndarray) -> dict[str, np.ndarray]:
    """The unmeasured pixels of ``x`` by where they lie in their column: above its top measurement
    (a sparser LiDAR's top line misses what the lines between it and the next reach), below its lowest,
    and between its lines within / beyond 8 px of a measurement. Columns without one: all ``above``."""
    measured = np.nan_to_num(x, nan=0.0) > 0
    rows = np.arange(x.shape[0])[:, None]
    top = np.where(measured.any(0), measured.argmax(0), x.shape[0])
    bottom = np.where(measured.any(0), x.shape[0] - 1 - measured[::-1].argmax(0), x.shape[0])
    near = cv2.distanceTransform((~measured).astype(np.uint8), cv2.DIST_L2, 5) <= 8
    above, below = rows < top, rows > bottom
    between = ~measured & ~above & ~below
    return {"above": above, "below": below, "between <=8 px": between & near, "between >8 px": between & ~near}


def density_table(set_name: str, frames: Any, methods: dict[str, Any], name: str | tuple[str, ...],
                  densities: tuple[str, ...], seeds: tuple[int, ...], label: str = "", regions: bool = False,
                  every: bool = False) -> None:
    """One line per density of ``frames`` (and per name, given several): ``methods[name]`` against the strongest
    classical fill, ms beside harmonic; with ``regions``, a line more per method: each :func:`column_regions` region's share of the
    scored pixels and of the squared error, and its RMSE; with ``every``, each method's mean RMSE and ms."""
    names, errs = (name,) if isinstance(name, str) else tuple(name), {}
    seconds: dict[tuple[str, str], float] = {}
    split: dict[tuple[str, str, str], np.ndarray] = {}  # (density, method, region): [pixels, squared error]
    for density, x, gt, scored in density_units(str(default_root()), frames, seeds, densities):
        parts = column_regions(x) if regions else {}
        for m, method in methods.items():
            start = time.perf_counter()
            pred = method.predict(x)
            seconds[density, m] = seconds.get((density, m), 0.0) + time.perf_counter() - start
            errs.setdefault((density, m), []).append(_rmse(pred, gt, scored))
            for region, inside in parts.items():
                se = (pred - gt)[scored & inside] ** 2
                split[density, m, region] = split.get((density, m, region), 0.0) + np.array([se.size, se.sum()])
    for density in (d for d in DENSITY_LABELS if d in densities):
        e = {m: np.asarray(errs[density, m]) for m in methods}
        best = min(CLASSICAL, key=lambda m: np.nanmean(e[m]))
        for n in names:
            r, lo, hi = paired_ratio(e[n], e[best])
            ms = {m: 1000.0 * seconds[density, m] / len(e[m]) for m in (n, "harmonic")}
            print(f"{label}{set_name:14s} {density:13s} | {n} {np.nanmean(e[n]):.3f} m, {best} {np.nanmean(e[best]):.3f}"
                  f" m, ratio {r:.3f} [{lo:.3f}, {hi:.3f}] | {ms[n]:.0f} vs harmonic {ms['harmonic']:.0f} ms/frame",
                  flush=True)
        for m in methods if every else ():
            print(f"{set_name:14s} {density:13s} {m:17s} rmse {np.nanmean(e[m]):.3f} m  "
                  f"{1000.0 * seconds[density, m] / len(e[m]):.0f} ms/frame", flush=True)
        for m in dict.fromkeys((*names, best)) if regions else ():
            cells = {k[2]: v for k, v in split.items() if k[:2] == (density, m)}
            n, sq = (sum(v[i] for v in cells.values()) for i in (0, 1))
            print(f"{label}{set_name:14s} {density:13s} | {m}: " + "; ".join(
                f"{region} {v[0] / n:.0%} px, {v[1] / sq:.0%} SE, {np.sqrt(v[1] / max(v[0], 1)):.2f} m"
                for region, v in cells.items()), flush=True)


def cmd_density(argv: list[str]) -> None:
    """A method against the strongest classical fill at every density and in holes, per set, ms beside harmonic."""
    parser = _parser("a method at every density and in holes cut into the scan", learned=False)
    parser.add_argument("--method", default="pretrained", help="a registered method name")
    parser.add_argument("--sets", default=",".join(DAYS + OFFICIAL_SETS), help="the sets, comma-separated")
    parser.add_argument("--densities", default=",".join(DENSITY_LABELS),
                        help=f"the inputs scored, comma-separated (of: {_LABELS_HELP})")
    parser.add_argument("--regions", action="store_true", help="also the error by region of the column (above "
                        "its top measurement, below its lowest, between its lines)")
    args = parser.parse_args(argv)
    sets = _sets(parser, args)
    methods = {args.method: make_method(args.method), **{m: make_method(m) for m in CLASSICAL}}
    for set_name in args.sets.split(","):
        density_table(set_name, sets[set_name], methods, args.method, tuple(args.densities.split(",")), _seeds(args),
                      regions=args.regions)


#: The distances (px to the nearest measurement) beyond which ``holes``' composition takes the map release.
HOLE_DISTANCES = (8, 16, 24, 32, 48, 64, 96)
HOLE_METHODS = ("pretrained", "kitti-ensemble-v1")


def enclosed_gap(x: np.ndarray) -> float:
    """The largest distance (px) to the nearest measurement over pixels that have a measurement above
    and below them in their column: a hole inside the scan, not the sky above its top lines."""
    measured = np.nan_to_num(x, nan=0.0) > 0
    below = np.cumsum(measured, axis=0) > 0
    above = np.cumsum(measured[::-1], axis=0)[::-1] > 0
    return float(np.max(gap_distance(x) * (below & above), initial=0.0))


def gap_distance(x: np.ndarray) -> np.ndarray:
    """Per pixel, its distance (px) to the nearest measurement, 0 outside the rows the measurements span
    (the distance ScanBlendInpainter's gate reads)."""
    measured = np.nan_to_num(x, nan=0.0) > 0
    rows = np.flatnonzero(measured.any(axis=1))
    gap = cv2.distanceTransform((~measured).astype(np.uint8), cv2.DIST_L2, 5)
    band = np.zeros(gap.shape, bool)
    band[rows[0] : rows[-1] + 1] = True
    return np.where(band, gap, 0.0)


def _rmse(pred: np.ndarray, gt: np.ndarray, scored: np.ndarray) -> float:
    return float(np.sqrt(np.mean((pred[scored] - gt[scored]) ** 2))) if scored.any() else np.nan


def hole_units(root: str, frames: Any, seeds: tuple[int, ...]) -> dict[str, dict[str, list[float]]]:
    """Per task (``rect-v1 hole``, ``64 beams``), per column, one value per unit: each method's RMSE,
    the composition's at each of :data:`HOLE_DISTANCES` (``blend D``), the default's and the map
    release's beyond D (``far D <method>``), the input's largest gap (``gap``: :func:`gap_distance`'s
    maximum; ``enclosed``: :func:`enclosed_gap`) and each method's seconds (``s <method>``)."""
    methods = {m: make_method(m) for m in HOLE_METHODS + CLASSICAL}
    out: dict[str, dict[str, list[float]]] = {}
    for label, x, gt, scored in density_units(root, frames, seeds, ("64 beams", "rect-v1 hole")):
        row = out.setdefault(label, {})
        preds = {}
        for m, method in methods.items():
            start = time.perf_counter()
            preds[m] = method.predict(x)
            row.setdefault(f"s {m}", []).append(time.perf_counter() - start)
            row.setdefault(m, []).append(_rmse(preds[m], gt, scored))
        gap = gap_distance(x)
        row.setdefault("gap", []).append(float(gap.max()))
        row.setdefault("enclosed", []).append(enclosed_gap(x))
        for d in HOLE_DISTANCES:
            far = gap > d
            row.setdefault(f"blend {d}", []).append(_rmse(np.where(far, preds[HOLE_METHODS[1]], preds[HOLE_METHODS[0]]),
                                                          gt, scored))
            for m in HOLE_METHODS:
                row.setdefault(f"far {d} {m}", []).append(_rmse(preds[m], gt, scored & far))
    return out


def _ratio_text(a: list[float], b: list[float]) -> str:
    r, lo, hi = paired_ratio(np.asarray(a), np.asarray(b))
    return f"{r:.3f} [{lo:.3f}, {hi:.3f}]"


def cmd_holes(argv: list[str]) -> None:
    """The default, the map release and the strongest classical fill in holes cut into scans, per set;
    the far-pixel composition with its distance chosen leaving one recording day out."""
    parser = _parser("the default vs the map release in holes cut into a scan", learned=False)
    parser.add_argument("--sets", default=",".join(DAYS + OFFICIAL_SETS), help="the sets, comma-separated")
    parser.add_argument("--save", help="JSON file to write every unit's values to")
    args = parser.parse_args(argv)
    sets, seeds, default, release = _sets(parser, args), _seeds(args), *HOLE_METHODS
    units = {}
    for name in args.sets.split(","):
        start = time.perf_counter()
        units[name] = hole_units(str(default_root()), sets[name], seeds)
        for label, row in units[name].items():
            best = min(CLASSICAL, key=lambda m: np.nanmean(row[m]))
            ms = {m: 1000.0 * np.mean(row[f"s {m}"]) for m in (default, release, "harmonic")}
            print(f"{name:14s} {label:13s} | {len(row[best])} units, {best} {np.nanmean(row[best]):.3f} m | {default} "
                  f"{np.nanmean(row[default]):.3f} m, ratio {_ratio_text(row[default], row[best])} | {release} "
                  f"{np.nanmean(row[release]):.3f} m, ratio {_ratio_text(row[release], row[best])} | release/default "
                  f"{_ratio_text(row[release], row[default])} | ms {ms[default]:.0f} / {ms[release]:.0f} / harmonic "
                  f"{ms['harmonic']:.0f} | largest gap {min(row['gap']):.0f}-{max(row['gap']):.0f} px, enclosed "
                  f"{min(row['enclosed']):.0f}-{max(row['enclosed']):.0f} px", flush=True)
            for d in HOLE_DISTANCES:
                far = [row[f"far {d} {m}"] for m in HOLE_METHODS]
                print(f"{name:14s} {label:13s} | D {d:3d}: composition ratio {_ratio_text(row[f'blend {d}'], row[best])},"
                      f" / default {_ratio_text(row[f'blend {d}'], row[default])} | beyond D: {default} "
                      f"{np.nanmean(far[0]):.3f} m, {release} {np.nanmean(far[1]):.3f} m, release/default "
                      f"{_ratio_text(far[1], far[0])}", flush=True)
        print(f"{name}: {time.perf_counter() - start:.0f} s", flush=True)
    if args.save:
        write_json(args.save, units)
    _holes_lodo({d: units[d] for d in DAYS if d in units}, {s: units[s] for s in OFFICIAL_SETS if s in units})


def _composition_ratio(row: dict[str, list[float]], d: int) -> float:
    best = min(CLASSICAL, key=lambda m: np.nanmean(row[m]))
    return paired_ratio(np.asarray(row[f"blend {d}"]), np.asarray(row[best]))[0]


def _holes_lodo(days: dict[str, Any], official: dict[str, Any]) -> None:
    """D chosen on two days (the mean of their hole ratios), scored on the third; the official sets
    with the D chosen on every day given."""
    label = "rect-v1 hole"
    if len(days) < 2:
        return
    for out in days:
        chosen = min(HOLE_DISTANCES, key=lambda d: np.mean([_composition_ratio(days[o][label], d)
                                                            for o in days if o != out]))
        row = days[out][label]
        best = min(CLASSICAL, key=lambda m: np.nanmean(row[m]))
        print(f"left out {out}: D {chosen} (chosen on {', '.join(o for o in days if o != out)}) | composition "
              f"{_ratio_text(row[f'blend {chosen}'], row[best])} vs default "
              f"{_ratio_text(row[HOLE_METHODS[0]], row[best])}", flush=True)
    chosen = min(HOLE_DISTANCES, key=lambda d: np.mean([_composition_ratio(days[o][label], d) for o in days]))
    for name, units in official.items():
        for task, row in units.items():
            best = min(CLASSICAL, key=lambda m: np.nanmean(row[m]))
            print(f"{name} {task}: D {chosen} (chosen on {', '.join(days)}) | composition "
                  f"{_ratio_text(row[f'blend {chosen}'], row[best])} vs default "
                  f"{_ratio_text(row[HOLE_METHODS[0]], row[best])}", flush=True)


COMMANDS = {"classical": cmd_classical, "lodo": cmd_lodo, "release": cmd_release, "official": cmd_official,
            "time": cmd_time, "density": cmd_density, "holes": cmd_holes}

if __name__ == "__main__":
    run_command("scan_lodo.py", COMMANDS, None)
