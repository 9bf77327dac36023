"""Valid-pixel density of the real KITTI slice vs SyntheticStreets (numbers in docs/data.md).

Run from the project root::

    python docs/scripts/data_density.py [--kitti-root <KITTI root>] [--n-synthetic 48]

For each source and kind: frames measured, mean/min/max fraction of pixels > 0 in the
352x1216 crop, and the first row (from the top of the crop) where more than 1 % of
the pixels are valid (the top of the LiDAR's field of view).
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import numpy as np

from inpaintenv.data import DepthDataset, KittiDepth, SyntheticStreets

ROOT = Path(__file__).resolve().parents[2]


def density_row(name: str, ds: DepthDataset) -> str:
    valid = np.stack([ds[i] > 0 for i in range(len(ds))])
    per_frame = valid.mean(axis=(1, 2))
    per_row = valid.mean(axis=(0, 2))
    first = int(np.argmax(per_row > 0.01))
    return (f"{name:<34} {len(ds):>6} {per_frame.mean():>7.1%} {per_frame.min():>7.1%} "
            f"{per_frame.max():>7.1%} {first:>9}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    default = os.environ.get("INPAINTENV_KITTI_ROOT")
    parser.add_argument("--kitti-root", default=default)
    parser.add_argument("--n-synthetic", type=int, default=48)
    args = parser.parse_args()
    print(f"{'source':<34} {'frames':>6} {'mean':>7} {'min':>7} {'max':>7} {'row >1 %':>9}")
    for kind in ("groundtruth", "velodyne_raw"):
        if args.kitti_root and Path(args.kitti_root).is_dir():
            print(density_row(f"KITTI train {kind}", KittiDepth(args.kitti_root, "train", kind=kind)))
        print(density_row(f"SyntheticStreets {kind}", SyntheticStreets(args.n_synthetic, seed=0, kind=kind)))
    print(density_row("SyntheticStreets dense", SyntheticStreets(args.n_synthetic, seed=0, kind="dense")))


if __name__ == "__main__":
    main()
