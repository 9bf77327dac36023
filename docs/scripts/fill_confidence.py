"""Make docs/img/fill_confidence.png: one KITTI frame filled by ``inpaintenv fill --confidence``.

The frame is an official KITTI validation-selection map (``depth_selection/val_selection_cropped``,
drive 2011_09_26_0002: never used to train or calibrate the default release), occluded with
mask 0 of ``rect-v1`` (seed 0). It is filled with ``fill(..., method="pretrained",
confidence=0.9)`` exactly as the command writes it, and the figure shows the input, the fill,
the width of the 90 % interval in the hole and the actual error where the map has truth,
with the frame's hole coverage in the title.

Run from the project root::

    python docs/scripts/fill_confidence.py --kitti-root <KITTI root>
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from inpaintenv.data import read_depth_png, write_depth_png  # noqa: E402
from inpaintenv.filling import fill  # noqa: E402
from inpaintenv.masks import get_protocol  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
FRAME = "2011_09_26_drive_0002_sync_groundtruth_depth_0000000005_image_02.png"


def main(argv: list[str] | None = None) -> Path:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--kitti-root", required=True)
    parser.add_argument("--out", default=str(ROOT / "docs" / "img" / "fill_confidence.png"))
    args = parser.parse_args(argv)
    gt = read_depth_png(Path(args.kitti_root) / "depth_selection" / "val_selection_cropped" / "groundtruth_depth" / FRAME)
    hole = get_protocol("rect-v1").mask(gt.shape, seed=0, index=0)
    with tempfile.TemporaryDirectory() as tmp:
        write_depth_png(Path(tmp) / "in" / "frame.png", np.where(hole, 0, gt))
        np.save(Path(tmp) / "hole.npy", hole)
        report = fill([Path(tmp) / "in"], Path(tmp) / "out", holes=Path(tmp) / "hole.npy", method="pretrained",
                      format="npy", confidence=0.9, progress=False)
        assert report.ok, report.failed
        filled, low, high = (np.load(Path(tmp) / "out" / f"frame{s}.npy") for s in ("", "_low", "_high"))
    scored = hole & (gt > 0)
    covered = float(((gt >= low) & (gt <= high))[scored].mean())
    width = np.where(hole, high - low, np.nan)
    error = np.where(scored, np.abs(filled - gt), np.nan)
    # The map has truth in its lower rows only: show the rows and columns that hold any.
    rows, cols = np.flatnonzero((gt > 0).any(1)), np.flatnonzero((gt > 0).any(0))
    crop = np.s_[rows[0]:rows[-1] + 1, cols[0]:cols[-1] + 1]
    panels = [("input (hole in white)", np.where(hole, np.nan, np.where(gt > 0, gt, np.nan)), "viridis", 60),
              ("pretrained fill (m)", np.where(filled > 0, filled, np.nan), "viridis", 60),
              ("width of the 90 % interval in the hole (m)", width, "magma", 15),
              ("actual |error| where the map has truth (m), same scale", error, "magma", 15)]
    fig, axes = plt.subplots(4, 1, figsize=(10, 8))
    for ax, (title, img, cmap, hi) in zip(axes, panels):
        ax.set_facecolor("white")
        im = ax.imshow(img[crop], cmap=cmap, vmin=0, vmax=hi, interpolation="nearest")
        ax.set_title(title, fontsize=10)
        ax.axis("off")
        fig.colorbar(im, ax=ax, fraction=0.015, pad=0.01)
    fig.suptitle(f"inpaintenv fill --confidence 0.9 on {FRAME[:26]} frame 5 (official map, never seen): "
                 f"{covered:.0%} of {int(scored.sum())} hole pixels inside their interval", fontsize=9)
    fig.tight_layout()
    out = Path(args.out)
    fig.savefig(out, dpi=90)
    print(f"{out}: coverage {covered:.3f} on {int(scored.sum())} hole pixels, mean width "
          f"{np.nanmean(width[scored]):.2f} m, hole RMSE {np.sqrt(np.nanmean(error[scored] ** 2)):.2f} m")
    return out


if __name__ == "__main__":
    main()
