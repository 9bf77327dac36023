"""Time per stage of the evaluation path at KITTI size: decode -> crop -> mask -> batch -> method -> metrics.

Usage (from the project root)::

    python perf/profile_pipeline.py                        # real KITTI slice if found
    python perf/profile_pipeline.py --frames 8 --repeats 3 --methods nearest telea
    python perf/profile_pipeline.py --synthetic            # force synthetic frames
    python perf/profile_pipeline.py --json out.json        # also write the numbers
    python perf/profile_pipeline.py --scaling              # cost vs frames and resolution

Input: ground-truth PNGs of the real KITTI slice (``$INPAINTENV_KITTI_ROOT`` or
``<KITTI root>``, split ``train``), bottom-centre cropped to 352x1216; without the
slice (or with ``--synthetic``), ``SyntheticStreets`` frames written to temporary
16-bit PNGs so the decode stage is still measured. Every stage runs on the same batch
of ``--frames`` frames; each stage is repeated ``--repeats`` times and the best run is
kept (the least disturbed by other jobs on a shared machine). Times are milliseconds
per frame of CPU time of this process and of wall-clock time. Single process;
estimators run with ``n_jobs=1``.

``--scaling`` instead times the whole ``inpaintenv.evaluate.evaluate`` loop (decode,
crop, mask, method, metrics) on the KITTI slice for several frame counts at 352x1216
and for several bottom-centre crop sizes, per method (and ``frame_metrics`` alone), and
fits ``seconds = a + b * frames`` and ``ms/frame = c + d * megapixels`` by least squares.
"""

from __future__ import annotations

import argparse
import os
import platform
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from inpaintenv.conventions import corrupt
from inpaintenv.data import (
    ArrayDataset,
    KittiDepth,
    SyntheticStreets,
    bottom_center_crop,
    read_depth_png,
    write_depth_png,
)

try:  # absent in trees before the cache existed (for before/after runs of this script)
    from inpaintenv.data.cache import CachedDataset
except ImportError:
    CachedDataset = None
from inpaintenv.files import write_json
from inpaintenv.masks import get_protocol
from inpaintenv.metrics import frame_metrics

ROOT = Path(__file__).resolve().parents[1]
SHAPE = (352, 1216)


def best_of(fn: Callable[[], Any], repeats: int) -> tuple[float, float, Any]:
    """Best CPU and best wall seconds over ``repeats`` calls, and the last result."""
    cpu, wall, out = [], [], None
    for _ in range(repeats):
        w0, c0 = time.perf_counter(), time.process_time()
        out = fn()
        cpu.append(time.process_time() - c0)
        wall.append(time.perf_counter() - w0)
    return min(cpu), min(wall), out


def png_paths(args: argparse.Namespace, tmp: Path) -> tuple[list[Path], str]:
    """Paths of ``args.frames`` ground-truth PNGs and a description of the source."""
    root = Path(args.kitti_root) if args.kitti_root else None
    if not args.synthetic and root is not None and (root / "train").is_dir():
        ds = KittiDepth(root, split="train")
        # Evenly spread over the slice's drives.
        idx = np.linspace(5, len(ds) - 6, args.frames).round().astype(int)
        return [ds.paths[i] for i in idx], f"KITTI slice {root} (train groundtruth, raw 1242x375)"
    ds_syn = SyntheticStreets(n=args.frames, seed=0, frame_shape=(375, 1242))
    paths = []
    for i in range(args.frames):
        p = tmp / f"{i:04d}.png"
        write_depth_png(p, ds_syn[i])
        paths.append(p)
    return paths, "SyntheticStreets groundtruth 1242x375 written to 16-bit PNG"


def classical_method(name: str) -> Any:
    """A classical estimator by short name, single-threaded."""
    from estimators.classical import (
        HarmonicInpainter,
        IPBasicInpainter,
        IterativeBilateralInpainter,
        NavierStokesInpainter,
        NearestInpainter,
        ScanlineInpainter,
        TeleaInpainter,
    )

    table = {
        "nearest": NearestInpainter,
        "telea": TeleaInpainter,
        "ns": NavierStokesInpainter,
        "ipbasic": IPBasicInpainter,
        "scanline": ScanlineInpainter,
        "harmonic": HarmonicInpainter,
        "bilateral": IterativeBilateralInpainter,
    }
    return table[name](n_jobs=1)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    default = os.environ.get("INPAINTENV_KITTI_ROOT")
    parser.add_argument("--kitti-root", default=default, help="KITTI root (default: $INPAINTENV_KITTI_ROOT)")
    parser.add_argument("--synthetic", action="store_true", help="use synthetic frames even if KITTI is present")
    parser.add_argument("--frames", type=int, default=8, help="frames in the batch")
    parser.add_argument("--repeats", type=int, default=3, help="runs per stage (best kept)")
    parser.add_argument("--protocol", default="rect-v1")
    parser.add_argument("--methods", nargs="*", default=["nearest", "telea", "ipbasic"])
    parser.add_argument("--json", type=Path, help="also write the results here")
    parser.add_argument("--scaling", action="store_true", help="fit cost vs frames and resolution instead")
    parser.add_argument("--sweep-frames", type=int, nargs="+", default=[4, 8, 16, 24])
    parser.add_argument("--sweep-crops", nargs="+", default=["88x304", "176x608", "264x912", "352x1216"],
                        help="crop sizes HxW for the resolution sweep")
    parser.add_argument("--crop-frames", type=int, default=6, help="frames per point of the resolution sweep")
    args = parser.parse_args()
    cv2.setNumThreads(1)  # one core per stage, comparable across runs
    if args.scaling:
        scaling(args)
        return

    rows: list[tuple[str, float, float]] = []
    n = args.frames

    def stage(name: str, fn: Callable[[], Any]) -> Any:
        cpu, wall, out = best_of(fn, args.repeats)
        rows.append((name, 1000 * cpu / n, 1000 * wall / n))
        return out

    with tempfile.TemporaryDirectory() as tmp_dir:
        paths, source = png_paths(args, Path(tmp_dir))
        for p in paths:  # warm the page cache: we time decoding, not the disk
            p.read_bytes()
        stage("read: cv2.imread (PNG decode, uint16)", lambda: [cv2.imread(str(p), cv2.IMREAD_UNCHANGED) for p in paths])
        raw = stage("read: read_depth_png (decode + checks + float32)", lambda: [read_depth_png(p) for p in paths])
        crops = stage("crop: bottom_center_crop to 352x1216", lambda: [bottom_center_crop(d, SHAPE) for d in raw])
        if not args.synthetic and (Path(args.kitti_root) / "train").is_dir():
            ds = KittiDepth(args.kitti_root, split="train")
            index = {p: i for i, p in enumerate(ds.paths)}
            idx = [index[p] for p in paths]
            stage("load: KittiDepth.load_batch (read+crop+stack)", lambda: ds.load_batch(idx))
            source_ds = ds[idx]
        else:
            source_ds = ArrayDataset(np.stack(crops))
        if CachedDataset is not None:
            cached = CachedDataset(source_ds, Path(tmp_dir) / "cache").build(progress=False)
            stage("load: CachedDataset.load_batch (uint16 memmap, built)", lambda: cached.load_batch(range(n)))
    gt = np.stack(crops)
    proto = get_protocol(args.protocol)
    hole = stage(f"mask: {proto.name} masks for the batch", lambda: proto.masks(SHAPE, 0, range(n)))
    x = stage("batch: corrupt (copy + NaN holes)", lambda: corrupt(gt, hole))
    for name in args.methods:
        est = classical_method(name)
        pred = stage(f"method: {type(est).__name__}.predict", lambda est=est: est.predict(x))
    stage("metrics: frame_metrics (batched)", lambda: frame_metrics(pred, gt, hole))

    print(f"source: {source}; {n} frames at {SHAPE[1]}x{SHAPE[0]}; best of {args.repeats}")
    print(f"python {platform.python_version()}, numpy {np.__version__}, opencv {cv2.__version__}, "
          f"{os.cpu_count()} cores, cv2 threads 1")
    print()
    print("| stage | CPU ms/frame | wall ms/frame |")
    print("|---|---:|---:|")
    for name, cpu, wall in rows:
        print(f"| {name} | {cpu:.2f} | {wall:.2f} |")
    if args.json:
        write_json(args.json, {
            "source": source, "frames": n, "shape": list(SHAPE), "repeats": args.repeats,
            "stages": [{"stage": s, "cpu_ms_per_frame": c, "wall_ms_per_frame": w} for s, c, w in rows],
        })


def fit_line(x: list[float], y: list[float]) -> tuple[float, float, float]:
    """Least-squares ``y = a + b x``; returns ``(a, b, r2)``."""
    xa, ya = np.asarray(x, float), np.asarray(y, float)
    b, a = np.polyfit(xa, ya, 1)
    resid = ya - (a + b * xa)
    ss = ((ya - ya.mean()) ** 2).sum()
    return float(a), float(b), float(1 - (resid**2).sum() / ss) if ss > 0 else 1.0


def scaling(args: argparse.Namespace) -> None:
    """Evaluation cost vs number of frames and vs resolution, with fitted lines."""
    from inpaintenv.evaluate import evaluate

    root = Path(args.kitti_root)
    if not (root / "train").is_dir():
        raise SystemExit(f"--scaling needs the KITTI slice (not found at {root})")

    class MetricsOnly:
        """Returns the ground truth's observed pixels (nearest-free): isolates load+mask+metrics."""

        name = "no method (load+mask+metrics)"
        batched = True

        def __call__(self, x: np.ndarray) -> np.ndarray:
            return np.nan_to_num(x, nan=1.0)  # filled: 0 m would be refused as unfilled

    methods = [("none", MetricsOnly())] + [(m, classical_method(m)) for m in args.methods]
    # The frames the sweeps use (positions 0-4 of every 40 are skipped).
    full = KittiDepth(root, split="train")
    usable = [i for i in range(len(full)) if i % 40 not in range(5)]

    def run(method: Any, ds: Any, n: int) -> tuple[float, float]:
        """Best CPU and best wall seconds of ``args.repeats`` evaluations of ``n`` frames."""
        cpu, wall, _ = best_of(
            lambda: evaluate(method, ds, protocol=args.protocol, seeds=(0,), n_frames=n, progress=False),
            args.repeats,
        )
        return cpu, wall

    report: dict[str, Any] = {"frames": {}, "resolution": {}}
    print(f"KITTI slice {root}; protocol {args.protocol}; best of {args.repeats}; "
          "CPU seconds of this process (wall in brackets)")
    print(f"python {platform.python_version()}, numpy {np.__version__}, opencv {cv2.__version__}, cv2 threads 1, n_jobs=1")
    print("\n## Cost vs frames at 352x1216: seconds = a + b * frames\n")
    print("| method | " + " | ".join(f"{n} fr" for n in args.sweep_frames) + " | a (s) | b (ms/frame) | R² |")
    print("|---|" + "---:|" * (len(args.sweep_frames) + 3))
    for key, method in methods:
        ds = full[usable[: max(args.sweep_frames)]]
        run(method, ds, 1)  # warm-up
        pts = [run(method, ds, n) for n in args.sweep_frames]
        a, b, r2 = fit_line(args.sweep_frames, [c for c, _ in pts])
        report["frames"][key] = {"points": pts, "a_s": a, "b_ms_per_frame": 1000 * b, "r2": r2}
        cells = " | ".join(f"{c:.2f} ({w:.2f})" for c, w in pts)
        print(f"| {getattr(method, 'name', type(method).__name__)} | {cells} | {a:.3f} | {1000 * b:.1f} | {r2:.4f} |")

    crops = [tuple(int(v) for v in c.split("x")) for c in args.sweep_crops]
    mpix = [h * w / 1e6 for h, w in crops]
    print(f"\n## Cost vs resolution ({args.crop_frames} frames per point): ms/frame = c + d * megapixels\n")
    print("| method | " + " | ".join(f"{w}x{h}" for h, w in crops) + " | c (ms) | d (ms/MP) | R² | k in ms ∝ MP^k |")
    print("|---|" + "---:|" * (len(crops) + 4))
    for key, method in methods:
        pts = []
        for crop in crops:
            ds = KittiDepth(root, split="train", crop=crop)[usable[: args.crop_frames]]
            c, w = run(method, ds, args.crop_frames)
            pts.append((1000 * c / args.crop_frames, 1000 * w / args.crop_frames))
        c0, d, r2 = fit_line(mpix, [c for c, _ in pts])
        # The exponent shows whether a straight line is the right model (k = 1: linear).
        _, k, _ = fit_line(list(np.log(mpix)), [float(np.log(c)) for c, _ in pts])
        report["resolution"][key] = {
            "megapixels": mpix, "points_ms": pts, "c_ms": c0, "d_ms_per_mp": d, "r2": r2, "exponent": k,
        }
        cells = " | ".join(f"{c:.1f} ({w:.1f})" for c, w in pts)
        print(f"| {getattr(method, 'name', type(method).__name__)} | {cells} | {c0:.2f} | {d:.1f} | {r2:.4f} | {k:.2f} |")

    # Two workers on this machine: only the method's frames run in parallel (evaluate's
    # loading and metrics stay in the calling thread).
    from joblib import parallel_config

    n = max(args.sweep_frames)
    print(f"\n## {n} frames at 352x1216 with joblib.parallel_config(backend, n_jobs=2) (wall seconds)\n")
    print("| method | n_jobs=1 | threading, 2 | loky, 2 | speed-up (best) |")
    print("|---|---:|---:|---:|---:|")
    ds = full[usable[:n]]
    for key, _ in methods[1:]:
        _, one = run(classical_method(key), ds, n)
        walls = []
        for backend in ("threading", "loky"):
            est = classical_method(key).set_params(n_jobs=None)
            with parallel_config(backend=backend, n_jobs=2):
                run(est, ds, 2)  # warm the pool
                walls.append(run(est, ds, n)[1])
        report.setdefault("parallel", {})[key] = {"n_jobs_1": one, "threading_2": walls[0], "loky_2": walls[1]}
        print(f"| {type(classical_method(key)).__name__} | {one:.2f} | {walls[0]:.2f} | {walls[1]:.2f} | {one / min(walls):.2f}x |")
    if args.json:
        write_json(args.json, report)


if __name__ == "__main__":
    main()
