"""``inpaintenv show``: one frame as a PNG panel (input | hole | ground truth | reconstruction |
error) with the method's metrics on it; or a picture of any depth file, folder of them (``fill``'s
output, with each file's interval width) or point cloud (``.bin``/``.ply``: from above and as a
camera sees it)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import numpy as np

from ..conventions import DEFAULT_MAX_DEPTH, check_max_depth, check_seed
from ..data.io import write_png
from .method_options import add_unfilled_option
from .options import (
    add_common_options,
    add_source_options,
    check_source_options,
    open_source_from_args,
)
from ..exceptions import InvalidInputError, OutOfRangeError

__all__ = ["add_show", "cmd_show"]


def add_show(subparsers: Any) -> None:
    p = subparsers.add_parser(
        "show", help="save a PNG panel of one frame, or a picture of a depth file, folder or point cloud",
        description="Save the panel input | hole | ground truth | reconstruction | error of one frame; or, given "
                    "PATH, a colour picture of a depth file (.png 16-bit, .npy, .npz; with its interval width when "
                    "<name>_low and <name>_high lie beside it, as fill --confidence writes them), of every such "
                    "file of a folder (into --out as a folder), or of a point cloud (.bin, .ply: from above and "
                    "as a camera at the sensor sees it).",
    )
    p.add_argument("path", nargs="?", metavar="PATH",
                   help="a depth file, a folder of them (e.g. fill's --out) or a point cloud to picture")
    p.add_argument("--method", "-m", metavar="NAME", help="method to run (default: none, data only)")
    p.add_argument("--index", type=int, default=0, help="frame index in the source (default 0)")
    p.add_argument("--seed", type=int, default=0, help="evaluation seed of the mask (default 0)")
    p.add_argument("--protocol", default="rect-v1", help="occlusion protocol (default rect-v1)")
    p.add_argument("--max-depth", type=float, default=DEFAULT_MAX_DEPTH, help="colour scale top in metres")
    p.add_argument("--out", help="PNG to write (default panel.png); for a folder PATH, the folder of the pictures "
                                 "(default pictures)")
    add_unfilled_option(p)
    add_source_options(p)
    add_common_options(p)
    p.set_defaults(func=cmd_show)


def _fmt(v: float, unit: str, digits: int = 3) -> str:
    return "n/a" if v is None or np.isnan(v) else f"{v:.{digits}f}{unit}"


def cmd_show(args: argparse.Namespace) -> int:
    import cv2

    from ..conventions import corrupt
    from ..envs.render import render_panel
    from ..methods.calls import run_method
    from ..masks import get_protocol
    from ..metrics import frame_metrics, interpolate_background
    from ..methods.registry import make_method, unfilled_policy

    if args.path is not None:
        return _show_path(Path(args.path), args.out)
    out = Path(args.out or "panel.png")
    # The panel is a PNG whatever the name: the suffix keeps names honest.
    if out.suffix.lower() != ".png":
        raise InvalidInputError(f"--out must be a .png file, got {args.out!r}")
    if out.is_dir():
        raise InvalidInputError(f"--out must be a .png file, got {args.out!r}, a folder")
    check_max_depth(args.max_depth, "--max-depth")
    check_seed(args.seed, "--seed")
    check_source_options(args)
    method = make_method(args.method) if args.method else None
    ds = open_source_from_args(args)
    if not 0 <= args.index < len(ds):
        raise OutOfRangeError(f"--index {args.index} is out of range for a source of {len(ds)} frames")
    proto = get_protocol(args.protocol)
    gt = ds[args.index]
    # The same mask evaluate() uses for (protocol, seed, index).
    hole = proto.mask(gt.shape, args.seed, args.index)
    lines = [f"{ds.frame_ids[args.index]}  {proto.name} seed {args.seed}  hole {100 * hole.mean():.1f} %"]
    pred = None
    if method is not None:
        batch, ms = run_method(method, corrupt(gt, hole)[None], args.method)
        policy = args.unfilled or unfilled_policy(args.method)
        # Shown as scored: after the devkit's interpolation when that is the policy.
        pred = interpolate_background(batch[0]) if policy == "interpolate" else batch[0]
        m = {k: float(v) for k, v in frame_metrics(pred, gt, hole, max_depth=args.max_depth, unfilled=policy).items()}
        lines.append(
            f"{args.method}: hole RMSE {_fmt(m['hole_rmse'], ' m')} MAE {_fmt(m['hole_mae'], ' m')} "
            f"PSNR {_fmt(m['hole_psnr'], ' dB', 2)} | all RMSE {_fmt(m['all_rmse'], ' m')} "
            f"PSNR {_fmt(m['all_psnr'], ' dB', 2)} | {ms:.0f} ms"
        )
    panel = render_panel(gt, hole, pred, max_depth=args.max_depth, title=lines)
    # Encoded in memory and written by Python: the error names the file and the cause
    # (read-only disk, full disk, permission), and any file name works.
    write_png(out, cv2.cvtColor(panel, cv2.COLOR_RGB2BGR), "panel")
    for line in lines:
        print(line)
    print(f"wrote {out} ({panel.shape[1]}x{panel.shape[0]})", file=sys.stderr)
    return 0


#: Names beside a depth file that are its interval or preview, not files of their own.
_BESIDE = ("_low", "_high", "_preview")


def _picture(source: Path, target: Path) -> str:
    """Draw the picture of one depth file or point cloud into ``target``; return a line saying what it shows."""
    from ..data.depth_files import read_depth_file
    from ..data.ply import read_points_ply
    from ..data.projection import read_scan
    from ..files import write_atomic
    from ..report.pictures import depth_figure, points_figure

    suffix = source.suffix.lower()
    if suffix in (".bin", ".ply"):
        points = read_scan(source) if suffix == ".bin" else read_points_ply(source)
        fig, what = points_figure(points, source.name), f"{len(points):,} points"
    else:
        depth = read_depth_file(source)
        low, high = (source.with_name(source.stem + s + source.suffix) for s in _BESIDE[:2])
        width = read_depth_file(high) - read_depth_file(low) if low.is_file() and high.is_file() else None
        fig = depth_figure(depth, source.name, width)
        what = f"{int((np.nan_to_num(depth) > 0).sum()):,} pixels with depth" + (" and the interval width"
                                                                                  if width is not None else "")
    import matplotlib.pyplot as plt

    try:
        write_atomic(target, lambda tmp: fig.savefig(tmp, format="png", dpi=100, bbox_inches="tight"), "picture")
    finally:
        plt.close(fig)
    return f"wrote {target} ({source.name}: {what})"


def _show_path(path: Path, out: str | None) -> int:
    """``inpaintenv show PATH``: a picture of a file, or one per depth file or point cloud of a folder."""
    from ..data.depth_files import DEPTH_SUFFIXES

    suffixes = (*DEPTH_SUFFIXES, ".bin", ".ply")
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such file or folder")
    if path.is_dir():
        folder = Path(out or "pictures")
        if folder.suffix.lower() == ".png" or folder.is_file():
            raise InvalidInputError(f"--out {folder}: a folder PATH gets one picture per file; give a folder")
        sources = sorted(f for f in path.rglob("*") if f.suffix.lower() in suffixes and f.is_file()
                         and not f.stem.endswith(_BESIDE) and not any(p.startswith(".") for p in f.parts))
        if not sources:
            raise InvalidInputError(f"{path} holds no depth file or point cloud ({', '.join(suffixes)})")
        for source in sources:
            rel = source.relative_to(path)
            print(_picture(source, folder / rel.with_name(rel.name.replace(".", "_") + ".png")), file=sys.stderr)
        return 0
    if path.suffix.lower() not in suffixes:
        raise InvalidInputError(f"{path}: not a depth file or point cloud (read are {', '.join(suffixes)})")
    target = Path(out or "panel.png")
    if target.suffix.lower() != ".png" or target.is_dir():
        raise InvalidInputError(f"--out must be a .png file, got {str(target)!r}")
    print(_picture(path, target), file=sys.stderr)
    return 0
