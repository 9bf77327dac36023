"""Options shared by several ``inpaintenv`` subcommands, and the data source they select.

``inpaintenv.cli`` and the subcommands defined in their own packages
(``inpaintenv.benchmark.command``) both import this module, so neither imports the other.
"""

from __future__ import annotations

import argparse
from typing import Any

__all__ = ["add_common_options", "add_source_options", "open_source_from_args"]


def add_source_options(parser: argparse.ArgumentParser) -> None:
    """Options choosing the data source: built-in synthetic streets, or real KITTI."""
    g = parser.add_argument_group("data source (default: built-in SyntheticStreets)")
    g.add_argument("--kitti-root", metavar="PATH", help="root of a KITTI depth-completion tree")
    g.add_argument("--split", default="train", help="KITTI split: train, val or val_selection, or several joined by commas, "
                   "e.g. train,val (default train)")
    g.add_argument("--camera", default="image_02", choices=["image_02", "image_03", "both"],
                   help="KITTI camera (default image_02)")
    g.add_argument(
        "--kind", default="groundtruth", choices=["groundtruth", "velodyne_raw", "dense"],
        help="ground truth to score against (default groundtruth; dense: synthetic only)",
    )
    g.add_argument("--drives", nargs="+", metavar="DRIVE", help="keep only these drives")
    g.add_argument("--exclude-drives", nargs="+", metavar="DRIVE",
                   help="drop these drives (e.g. the ones a model was trained on)")
    g.add_argument("--n-frames", type=int, metavar="N", help="use only the first N frames")
    g.add_argument(
        "--frame-shape", type=int, nargs=2, metavar=("H", "W"),
        help="synthetic frame size (default 352 1216, KITTI's crop)",
    )
    g.add_argument("--data-seed", type=int, default=0, help="seed of the synthetic streets (default 0)")


def add_common_options(parser: argparse.ArgumentParser) -> None:
    """Options every subcommand takes."""
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bars")


def open_source_from_args(args: argparse.Namespace) -> Any:
    """Build the data source selected by :func:`add_source_options`' options.

    Uses :func:`inpaintenv.data.open_source`: ``--kitti-root`` gives ``KittiDepth``
    (first ``--n-frames`` frames), otherwise the built-in ``SyntheticStreets``
    (``--n-frames`` frames, 64 by default; ``--frame-shape`` sets their size).
    """
    from .data import open_source

    if args.n_frames is not None and args.n_frames < 1:
        raise ValueError(f"--n-frames must be >= 1, got {args.n_frames}")
    if args.frame_shape:
        if args.kitti_root:
            raise ValueError("--frame-shape applies to the synthetic source only (KITTI is cropped to 352x1216)")
        from .data import SyntheticStreets, select_drives
        from .data.sources import DEFAULT_SYNTHETIC_FRAMES

        return select_drives(
            SyntheticStreets(
                n=args.n_frames or DEFAULT_SYNTHETIC_FRAMES, seed=args.data_seed, kind=args.kind,
                frame_shape=tuple(args.frame_shape),
            ),
            args.drives, args.exclude_drives,
        )
    return open_source(
        args.kitti_root, split=args.split, kind=args.kind, n_frames=args.n_frames,
        seed=args.data_seed, camera=args.camera, drives=args.drives,
        exclude_drives=args.exclude_drives,
    )
