"""How the learned-vs-classical ratio moves when the camera's focal length changes.

Another rig sees the same street at another scale: KITTI-360's perspective camera has a
focal length of about 552 px against KITTI's 721 px, so a car, a kerb or a LiDAR ring covers
0.77 times as many pixels. This probe simulates that on KITTI ground truth by resampling
each map by a factor ``s`` (nearest neighbour: a measured depth is moved, never blended with
its neighbours, so density stays that of the source map), then scores every method under
one occlusion protocol (rect-v1 holes are a share of the frame, so they scale with it) and
prints, per factor, the best learned method over the strongest classical one with the paired
95 % interval (:func:`inpaintenv.benchmark.headline.learned_vs_classical`, pooled over the
frames). Score models on frames they were not trained on, e.g. a leave-drive-0001-out
fold model (``experiments/lodo_days.sh``) on drive 0001.

Examples
--------
    python experiments/focal_probe.py --kitti-root <KITTI root> --drive 2011_09_26_drive_0001_sync \\
        --camera both lodo/train-drive-0001-context-kitti-draws/model -m harmonic -m scanline \\
        --scale 1 --scale 0.77
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from inpaintenv.benchmark.headline import CLASSICAL_METHODS, learned_vs_classical
from inpaintenv.data.base import DepthDataset
from inpaintenv.data.kitti import KittiDepth
from inpaintenv.evaluate import evaluate
from inpaintenv.registry import make_method
from inpaintenv.report.results import EvaluationResult

#: KITTI-360 perspective focal length over KITTI's (552.55 px / 721.54 px).
KITTI360_SCALE = 0.766


def nearest_indices(n_in: int, scale: float) -> np.ndarray:
    """Source index of each of the ``round(n_in * scale)`` output positions (pixel centres)."""
    n_out = max(1, round(n_in * scale))
    return np.minimum(((np.arange(n_out) + 0.5) * (n_in / n_out)).astype(np.int64), n_in - 1)


class Resampled(DepthDataset):
    """``dataset`` resampled by ``scale`` in both axes, nearest neighbour (depth never blended).

    Parameters
    ----------
    dataset : DepthDataset
        The ground truth to resample.
    scale : float
        Output size over input size, > 0 (< 1: a shorter focal length, a wider view).
    """

    def __init__(self, dataset: DepthDataset, scale: float) -> None:
        if not (math.isfinite(scale) and scale > 0):
            raise ValueError(f"scale must be a finite number > 0, got {scale}")
        self.dataset, self.scale = dataset, float(scale)
        h, w = dataset.frame_shape
        self._rows, self._cols = nearest_indices(h, scale), nearest_indices(w, scale)
        self.frame_shape = (len(self._rows), len(self._cols))
        self.groups, self.frame_ids = dataset.groups, list(dataset.frame_ids)

    def _load(self, index: int) -> np.ndarray:
        return np.ascontiguousarray(self.dataset[index][np.ix_(self._rows, self._cols)])


def load_method(spec: str) -> tuple[str, Any]:
    """A saved model folder (named after its run folder) or a registry name."""
    path = Path(spec)
    if path.is_dir():
        run = path.parent.name if path.name == "model" else path.name
        return run, make_method("checkpoint", path=path)
    return spec, make_method(spec)


def probe(methods: list[tuple[str, Any]], frames: DepthDataset, scales: list[float], protocol: str,
          seeds: list[int]) -> list[dict]:
    """One headline entry per scale: best learned ÷ strongest classical on the resampled frames."""
    entries = []
    for scale in scales:
        data = Resampled(frames, scale)
        rows: list[dict] = []
        for name, method in methods:
            rows += evaluate(method, data, protocol, seeds, name=name, progress=False, warmup=True).rows
        for entry in learned_vs_classical(EvaluationResult(rows=rows), keys=("protocol",)):
            entries.append({"scale": scale, "frame_shape": list(data.frame_shape), **entry})
    return entries


def main(argv: list[str] | None = None) -> list[dict]:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("models", nargs="+", help="saved model folders or registry names of learned methods")
    p.add_argument("-m", "--method", action="append", default=[], help="classical registry method (repeatable)")
    p.add_argument("--kitti-root", required=True)
    p.add_argument("--split", default="train")
    p.add_argument("--drive", action="append", help="a drive to score (repeatable; default: all of the split)")
    p.add_argument("--camera", default="image_02")
    p.add_argument("--scale", type=float, action="append", help=f"resampling factor (repeatable; default 1 and {KITTI360_SCALE})")
    p.add_argument("--seed", type=int, action="append", help="mask seed (repeatable; default 0 and 1)")
    p.add_argument("--protocol", default="rect-v1")
    p.add_argument("--out", help="write the entries to this JSON file")
    args = p.parse_args(argv)
    unknown = [m for m in args.method if m not in CLASSICAL_METHODS]
    if unknown:
        p.error(f"-m takes classical methods (the ratio's denominator); not classical: {', '.join(unknown)}")
    frames = KittiDepth(args.kitti_root, split=args.split, drives=args.drive, camera=args.camera)
    methods = [load_method(m) for m in args.models] + [(m, make_method(m)) for m in args.method]
    entries = probe(methods, frames, args.scale or [1.0, KITTI360_SCALE], args.protocol, args.seed or [0, 1])
    print("| scale | frame | learned (hole RMSE) | strongest classical | ratio [paired 95 %] | frame-masks |")
    print("|---:|---|---|---|---:|---:|")
    for e in entries:
        h, w = e["frame_shape"]
        print(f"| {e['scale']:g} | {w}×{h} | {e['learned']} {e['learned_hole_rmse']:.2f} m | "
              f"{e['classical']} {e['classical_hole_rmse']:.2f} m | {e['hole_ratio']:.3f} "
              f"[{e['hole_ratio_low']:.2f}, {e['hole_ratio_high']:.2f}] | {e['hole_ratio_n']} |")
    if args.out:
        Path(args.out).write_text(json.dumps(entries, indent=2, default=str))
    return entries


if __name__ == "__main__":
    main()
