"""``inpaintenv show``: one frame as a PNG panel (input | hole | ground truth | reconstruction |
error) with the method's metrics on it."""

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
        "show", help="save a PNG panel of one frame",
        description="Save the panel input | hole | ground truth | reconstruction | error of one frame.",
    )
    p.add_argument("--method", "-m", metavar="NAME", help="method to run (default: none, data only)")
    p.add_argument("--index", type=int, default=0, help="frame index in the source (default 0)")
    p.add_argument("--seed", type=int, default=0, help="evaluation seed of the mask (default 0)")
    p.add_argument("--protocol", default="rect-v1", help="occlusion protocol (default rect-v1)")
    p.add_argument("--max-depth", type=float, default=DEFAULT_MAX_DEPTH, help="colour scale top in metres")
    p.add_argument("--out", default="panel.png", help="PNG to write (default panel.png)")
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

    out = Path(args.out)
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
