"""Compiled vs eager prediction of a saved neural model: time and largest difference.

Examples
--------
    python perf/compile_parity.py runs/unet-frame/model --kitti-root <KITTI root> \\
        --drives 2011_09_26_drive_9002_sync --frames 2

Without ``--kitti-root`` the frames are SyntheticStreets frames.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from estimators.learned import load
from inpaintenv.data import SyntheticStreets
from inpaintenv.data.kitti import KittiDepth
from inpaintenv.masks import get_protocol


def main(argv: list[str] | None = None) -> dict:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("checkpoint", help="a model folder written by .save() or inpaintenv train")
    p.add_argument("--kitti-root")
    p.add_argument("--drives", nargs="*")
    p.add_argument("--frames", type=int, default=2)
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--mode", default="default", help="torch.compile mode")
    args = p.parse_args(argv)

    ds = (KittiDepth(args.kitti_root, split="train", drives=args.drives) if args.kitti_root
          else SyntheticStreets(n=args.frames, seed=0))
    n = min(args.frames, len(ds))
    gt = ds.load_batch(range(n))
    hole = get_protocol("rect-v1").masks(gt.shape[1:], 0, range(n))
    x = np.where(hole, np.nan, gt).astype(np.float32)
    est = load(args.checkpoint).set_params(num_threads=args.threads, keep_observed=False)
    t = time.perf_counter()
    eager = est.predict(x)
    eager_s = time.perf_counter() - t
    est.set_params(compile=True if args.mode == "default" else args.mode)
    t = time.perf_counter()
    est.predict(x)
    first_s = time.perf_counter() - t
    t = time.perf_counter()
    compiled = est.predict(x)
    again_s = time.perf_counter() - t
    diff = np.abs(compiled - eager)
    result = {"frames": n, "eager_s": round(eager_s, 2), "compiled_first_s": round(first_s, 2),
              "compiled_s": round(again_s, 2), "max_abs_diff_m": float(diff.max()),
              "mean_abs_diff_m": float(diff.mean())}
    print(json.dumps(result))
    return result


if __name__ == "__main__":
    main()
