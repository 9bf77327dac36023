"""Make docs/img/data_synthetic_vs_kitti.png: a real KITTI frame next to synthetic ones.

Run from the project root::

    python docs/scripts/data_synthetic_vs_kitti.py [--kitti-root <KITTI root>]
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from inpaintenv.data import KittiDepth, SyntheticStreets  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]


def _show(ax, depth: np.ndarray, title: str) -> None:
    shown = np.ma.masked_equal(depth, 0.0)  # no measurement stays white
    ax.imshow(shown, cmap="turbo_r", vmin=0, vmax=80, interpolation="nearest")
    ax.set_title(f"{title}  ({(depth > 0).mean():.1%} valid)", fontsize=9)
    ax.set_axis_off()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    default = os.environ.get("INPAINTENV_KITTI_ROOT")
    parser.add_argument("--kitti-root", default=default)
    parser.add_argument("--out", default=str(ROOT / "docs" / "img" / "data_synthetic_vs_kitti.png"))
    args = parser.parse_args()

    if not args.kitti_root:
        parser.error("needs real KITTI: pass --kitti-root <KITTI root> or set INPAINTENV_KITTI_ROOT")
    real_gt = KittiDepth(args.kitti_root, split="train", kind="groundtruth")
    real_raw = KittiDepth(args.kitti_root, split="train", kind="velodyne_raw")
    i = 20  # a frame with both kinds present (gt starts at frame 5 of a drive)
    fid = real_gt.frame_ids[i]
    j = real_raw.frame_ids.index(fid)
    panels = [
        (real_gt[i], f"KITTI groundtruth {fid}"),
        (real_raw[j], "KITTI velodyne_raw (same frame)"),
        (SyntheticStreets(n=8, seed=0, kind="dense")[3], "SyntheticStreets dense (seed 0, frame 3)"),
        (SyntheticStreets(n=8, seed=0, kind="groundtruth")[3], "SyntheticStreets groundtruth"),
        (SyntheticStreets(n=8, seed=0, kind="velodyne_raw")[3], "SyntheticStreets velodyne_raw"),
        (SyntheticStreets(n=16, seed=1, kind="groundtruth")[12], "SyntheticStreets groundtruth (seed 1, frame 12)"),
    ]
    fig, axes = plt.subplots(3, 2, figsize=(16, 7.2), constrained_layout=True)
    for ax, (depth, title) in zip(axes.ravel(), panels):
        _show(ax, depth, title)
    sm = plt.cm.ScalarMappable(cmap="turbo_r", norm=plt.Normalize(0, 80))
    fig.colorbar(sm, ax=axes, shrink=0.6, label="depth [m] (white = no measurement)")
    fig.savefig(args.out, dpi=100)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
