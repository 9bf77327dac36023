"""Make docs/img/protocol_<name>.png: sample masks of each occlusion protocol in red on KITTI.

The background is a real KITTI ground-truth frame (read at run time from
``--kitti-root``, ``$INPAINTENV_KITTI_ROOT`` or ``<KITTI root>``; falls back to a
``SyntheticStreets`` frame, and says so in the title, when no KITTI slice is found).
Each panel is the mask of ``(protocol, seed=0, index=i)`` for ``i = 0..5``.

Run from the project root::

    python docs/scripts/protocol_gallery.py [--kitti-root <KITTI root>] [--protocols rect-v1 ...]
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
from inpaintenv.masks import available_protocols, get_protocol  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
RED = np.array([1.0, 0.1, 0.1])


def background(kitti_root: str | None) -> tuple[np.ndarray, str]:
    """A 352×1216 depth frame and a caption saying where it comes from."""
    if kitti_root and Path(kitti_root, "train").is_dir():
        ds = KittiDepth(kitti_root, split="train", kind="groundtruth")
        i = 20
        return ds[i], f"KITTI groundtruth {ds.frame_ids[i]}"
    return SyntheticStreets(n=4, seed=0, kind="groundtruth")[1], "SyntheticStreets (no KITTI slice found)"


def overlay(depth: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Grey depth (near = bright, no data = black) with the mask blended in red."""
    grey = np.where(depth > 0, 1.0 - np.clip(depth / 80.0, 0, 1) * 0.8, 0.0)
    rgb = np.repeat(grey[..., None], 3, axis=2)
    rgb[mask] = 0.35 * rgb[mask] + 0.65 * RED
    return rgb


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    default = os.environ.get("INPAINTENV_KITTI_ROOT")
    parser.add_argument("--kitti-root", default=default)
    parser.add_argument("--protocols", nargs="*", default=available_protocols())
    parser.add_argument("--out-dir", default=str(ROOT / "docs" / "img"))
    args = parser.parse_args()

    depth, source = background(args.kitti_root)
    for name in args.protocols:
        proto = get_protocol(name)
        fig, axes = plt.subplots(3, 2, figsize=(14, 7.0), constrained_layout=True)
        for i, ax in enumerate(axes.ravel()):
            mask = proto.mask(depth.shape, seed=0, index=i)
            ax.imshow(overlay(depth, mask), interpolation="nearest")
            ax.set_title(f"seed 0, index {i}: hole {mask.mean():.1%} of the frame", fontsize=9)
            ax.set_axis_off()
        fig.suptitle(f"{name}: {proto.description}\nbackground: {source}", fontsize=10)
        out = Path(args.out_dir) / f"protocol_{name}.png"
        fig.savefig(out, dpi=80)
        plt.close(fig)
        print(f"wrote {out}")


if __name__ == "__main__":
    main()
