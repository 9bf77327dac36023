"""Time per stage of the evaluation path at KITTI size: decode -> crop -> mask -> batch -> method -> metrics.

Usage (from the project root)::

    python benchmarks/profile_pipeline.py                        # real KITTI slice if found
    python benchmarks/profile_pipeline.py --frames 8 --repeats 3 --methods nearest telea
    python benchmarks/profile_pipeline.py --synthetic            # force synthetic frames
    python benchmarks/profile_pipeline.py --json out.json        # also write the numbers

Input: ground-truth PNGs of the real KITTI slice (``$INPAINTENV_KITTI_ROOT`` or
``../shared/kitti``, split ``train``), bottom-centre cropped to 352x1216; without the
slice (or with ``--synthetic``), ``SyntheticStreets`` frames written to temporary
16-bit PNGs so the decode stage is still measured. Every stage runs on the same batch
of ``--frames`` frames; each stage is repeated ``--repeats`` times and the best run is
kept (the least disturbed by other jobs on a shared machine). Times are milliseconds
per frame of CPU time of this process and of wall-clock time. Single process;
estimators run with ``n_jobs=1``.
"""

from __future__ import annotations

import argparse
import json
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
from inpaintenv.data import ArrayDataset, KittiDepth, SyntheticStreets, bottom_center_crop, read_depth_png, write_depth_png
from inpaintenv.data.cache import CachedDataset
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
    root = Path(args.kitti_root)
    if not args.synthetic and (root / "train").is_dir():
        ds = KittiDepth(root, split="train")
        # Frames with ground truth (the first/last 5 of a drive have none).
        idx = np.linspace(5, len(ds) - 6, args.frames).round().astype(int)
        return [ds.paths[i] for i in idx], f"KITTI slice {root} (train groundtruth, raw 1242x375)"
    ds_syn = SyntheticStreets(n=args.frames, seed=0, frame_shape=(375, 1242))
    paths = []
    for i in range(args.frames):
        p = tmp / f"{i:04d}.png"
        write_depth_png(p, ds_syn[i])
        paths.append(p)
    return paths, "SyntheticStreets groundtruth 1242x375 written to 16-bit PNG"


def make_method(name: str) -> Any:
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
    default = os.environ.get("INPAINTENV_KITTI_ROOT", str(ROOT.parent / "shared" / "kitti"))
    parser.add_argument("--kitti-root", default=default, help="KITTI root (default: $INPAINTENV_KITTI_ROOT or ../shared/kitti)")
    parser.add_argument("--synthetic", action="store_true", help="use synthetic frames even if KITTI is present")
    parser.add_argument("--frames", type=int, default=8, help="frames in the batch")
    parser.add_argument("--repeats", type=int, default=3, help="runs per stage (best kept)")
    parser.add_argument("--protocol", default="rect-v1")
    parser.add_argument("--methods", nargs="*", default=["nearest", "telea", "ipbasic"])
    parser.add_argument("--json", type=Path, help="also write the results here")
    args = parser.parse_args()
    cv2.setNumThreads(1)  # one core per stage, comparable across runs

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
        cached = CachedDataset(source_ds, Path(tmp_dir) / "cache").build(progress=False)
        stage("load: CachedDataset.load_batch (uint16 memmap, built)", lambda: cached.load_batch(range(n)))
    gt = np.stack(crops)
    proto = get_protocol(args.protocol)
    hole = stage(f"mask: {proto.name} masks for the batch", lambda: proto.masks(SHAPE, 0, range(n)))
    x = stage("batch: corrupt (copy + NaN holes)", lambda: corrupt(gt, hole))
    for name in args.methods:
        est = make_method(name)
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
        args.json.write_text(json.dumps({
            "source": source, "frames": n, "shape": list(SHAPE), "repeats": args.repeats,
            "stages": [{"stage": s, "cpu_ms_per_frame": c, "wall_ms_per_frame": w} for s, c, w in rows],
        }, indent=1))


if __name__ == "__main__":
    main()
