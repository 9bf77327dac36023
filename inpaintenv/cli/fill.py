"""``inpaintenv fill``: fill your own depth maps and LiDAR scans, files or folders in, filled files out.

Parsing only: :func:`inpaintenv.filling.fill` does the work.
"""

from __future__ import annotations

import argparse
from typing import Any

from ..exceptions import InpaintenvError, InvalidInputError
from ..methods.learned import DEFAULT_RELEASE
from ..methods.registry import shipped_interval_calibrations
from .messages import print_line
from .method_options import check_checkpoint_folder, check_method_names
from .options import add_common_options

__all__ = ["RECIPES", "add_fill", "cmd_fill"]

#: The three recipes of docs/fill.md, shown by ``inpaintenv fill --help``.
RECIPES = """\
recipes (docs/fill.md):
  a folder of KITTI 16-bit PNGs with a folder of masks (same relative paths, nonzero = fill):
    inpaintenv fill depth/ --holes masks/ --out filled/
  .npy float metres with NaN where to fill (written as .npy, and as PNG with --format both):
    inpaintenv fill frames/ --format npy --out filled/
  the same, with a 90 % interval per pixel beside each filled map (<name>_low, <name>_high):
    inpaintenv fill frames/ --format npy --confidence 0.9 --out filled/
  a LiDAR scan with its calibration, densified within its field of view (--fill-all: the sky too),
  with the filled points back in the LiDAR frame:
    inpaintenv fill 2011_09_26_drive_0001_sync/velodyne_points/data/ --calib 2011_09_26/ \\
        --missing --points bin --out filled/

  Pixels to fill: NaN in arrays, --holes, --box (repeatable) and --missing, together. Measured
  pixels come out bit-identical. Outputs this command made are skipped (rerun to resume), others
  refused (--overwrite replaces them); a bad file is one line and the others are still written;
  the exit status is 1 if any failed.
"""


def _box(text: str) -> tuple[int, int, int, int]:
    parts = text.split(",")
    try:
        values = tuple(int(p) for p in parts)
    except ValueError:
        values = ()
    if len(values) != 4:
        raise argparse.ArgumentTypeError(f"a box is x0,y0,x1,y1 in pixels (four integers), got {text!r}")
    return values  # type: ignore[return-value]


def _size(text: str) -> tuple[int, int]:
    from ..data.calibration import parse_size

    try:
        return parse_size(text)
    except (ValueError, InpaintenvError) as exc:  # a bad size, or more pixels than a frame may have
        raise argparse.ArgumentTypeError(str(exc).removesuffix("; not read")) from None


def add_fill(subparsers: Any) -> None:
    """Declare ``inpaintenv fill``."""
    p = subparsers.add_parser(
        "fill", help="fill your own depth maps (PNG, NPY) and LiDAR scans: files or folders in, filled files out",
        description=(
            "Fill the holes of depth files and LiDAR scans with any method. INPUT: files or folders (read "
            "recursively; each output keeps its path relative to its INPUT): KITTI 16-bit depth PNGs (metres x 256, "
            "0 = no measurement), .npy/.npz float metres (NaN = fill, 0 = no measurement) and .bin LiDAR scans "
            "(with --calib). Inputs are never changed, and nothing is written into an input folder."
        ),
        epilog=RECIPES, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("inputs", nargs="+", metavar="INPUT", help="depth files, scans, or folders of them")
    p.add_argument("--out", required=True, metavar="DIR", help="folder of the filled files")
    g = p.add_argument_group("which pixels to fill (NaN in arrays, and any of these, together)")
    g.add_argument("--holes", metavar="PATH",
                   help="a mask for every input, or a folder of masks matched by relative path (PNG or NPY, "
                        "nonzero = fill)")
    g.add_argument("--box", type=_box, action="append", default=[], metavar="x0,y0,x1,y1",
                   help="a rectangle to fill: columns x0..x1-1, rows y0..y1-1 (repeatable)")
    g.add_argument("--missing", action="store_true",
                   help="fill the pixels without a measurement (densify) inside the scan's field of view: per column "
                        "between its topmost and bottommost measured rows, not the sky above")
    g.add_argument("--fill-all", action="store_true",
                   help="with --missing: every pixel without a measurement, the sky included")
    s = p.add_argument_group("LiDAR scans (.bin, N x 4 float32)")
    s.add_argument("--calib", metavar="PATH",
                   help="a KITTI raw day folder (calib_cam_to_cam.txt + calib_velo_to_cam.txt), an odometry calib.txt "
                        "(with --size), or a KITTI-360 calibration folder (perspective.txt + calib_cam_to_velo.txt)")
    s.add_argument("--size", type=_size, metavar="WxH", help="image size, e.g. 1226x370 (needed for odometry)")
    s.add_argument("--camera", type=int, metavar="N",
                   help="camera to project into: 2 (default) or 3 for raw/odometry, 0 (default) or 1 for KITTI-360")
    s.add_argument("--points", choices=["bin", "ply", "both"],
                   help="also write the scan's points plus the filled pixels back-projected (reflectance 0)")
    o = p.add_argument_group("output and method")
    o.add_argument("--format", choices=["png", "npy", "both"], default="png",
                   help="depth files written: png (KITTI 16-bit, the default), npy (float metres) or both")
    which = o.add_mutually_exclusive_group()
    which.add_argument("--method", "-m", default="pretrained", metavar="NAME",
                       help="method name (default pretrained); see `inpaintenv info` for the list")
    which.add_argument("--checkpoint", metavar="PATH", help="a saved model's folder instead of --method")
    o.add_argument("--input", choices=["auto", "scan", "map"],
                   help="what the inputs are, for a method that fills each kind its own way (pretrained: a single "
                        "LiDAR scan with kitti-scan-v1, a map with holes with the map release): auto (its "
                        "default) tells each input's kind from its measured density; the output line says which "
                        "method filled what")
    c = p.add_argument_group("per-pixel confidence")
    c.add_argument("--confidence", type=float, nargs="?", const=0.9, metavar="COVERAGE",
                   help="also write an interval of this nominal coverage beside each depth file, <name>_low and "
                        "<name>_high in the same format (default 0.9 when given alone); shipped with their "
                        f"calibration: {', '.join(shipped_interval_calibrations())} (pretrained is "
                        f"{DEFAULT_RELEASE}); other methods need --intervals")
    c.add_argument("--intervals", metavar="CAL.json",
                   help="a saved interval calibration of the method (ConformalIntervalInpainter.save), for "
                        "--confidence")
    o.add_argument("--preview", action="store_true",
                   help="also write <name>_preview.png beside each input's outputs: an 8-bit colour picture of the "
                        "input, the fill and (with --confidence) the interval width, one depth scale in metres with "
                        "its colour bar")
    o.add_argument("--jobs", type=int, metavar="N", help="parallel frames for the classical methods")
    o.add_argument("--batch-size", type=int, default=4, metavar="N", help="same-sized frames per call (default 4)")
    o.add_argument("--overwrite", action="store_true",
                   help="redo inputs whose outputs exist; otherwise they are skipped when this command made them "
                        "(same input, method and options: the ledger inpaintenv-fill.jsonl in --out), and refused "
                        "in one line when not")
    o.add_argument("--on-error", choices=["continue", "stop"], default="continue",
                   help="a bad input is one line and the run goes on (continue, the default), or stops there")
    add_common_options(p)
    p.set_defaults(func=cmd_fill, on_interrupt=_fill_interrupted)


def _fill_interrupted(args: argparse.Namespace) -> str:
    return (f"the files written so far are kept in {args.out} (each complete); rerun the same command to go on "
            "(existing outputs are skipped)")


def cmd_fill(args: argparse.Namespace) -> int:
    """Run ``inpaintenv fill``."""
    from ..filling import FillOptions, fill

    method: Any = None if args.checkpoint else check_method_names([args.method])[0]
    checkpoint = check_checkpoint_folder(args.checkpoint) if args.checkpoint else None
    if args.jobs is not None and args.jobs == 0:
        raise InvalidInputError("--jobs must be a non-zero integer (-1 = every core), got 0")

    def log(line: str) -> None:
        print_line(f"inpaintenv fill: {line}")

    options = FillOptions(
        checkpoint=checkpoint, holes=args.holes, boxes=args.box, missing=args.missing, fill_all=args.fill_all,
        calibration=args.calib, size=args.size, camera=args.camera, format=args.format, points=args.points,
        overwrite=args.overwrite, on_error=args.on_error, n_jobs=args.jobs, batch_size=args.batch_size,
        progress=not args.quiet, log=log, confidence=args.confidence, intervals=args.intervals, input=args.input,
        preview=args.preview,
    )
    report = fill(args.inputs, args.out, method=method, options=options)
    print_line(report.summary())
    return 0 if report.ok else 1
