"""``inpaintenv export``: the occluded inputs of a data source and protocol as files, for a
method that runs anywhere (``inpaintenv score`` scores its predictions)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from .options import (
    SYNTHETIC_HOLDOUT,
    add_common_options,
    add_source_options,
    open_source_from_args,
    test_split,
)
from ..exceptions import InvalidInputError
from ..data.inputs import INPUT_KINDS

__all__ = ["add_export", "cmd_export"]


def add_export(subparsers: Any) -> None:
    """Declare ``inpaintenv export``."""

    p = subparsers.add_parser(
        "export", help="write the occluded inputs as PNG files for a method run elsewhere",
        description=(
            "Write, for every frame, the occluded input (the ground truth with the hole cut, or with --input scan "
            "the frame's single LiDAR scan with the hole cut) as a KITTI 16-bit depth PNG (0 = hole or no "
            "measurement) and the hole mask as an 8-bit PNG, in KITTI's folder layout, plus manifest.json: the kit "
            "for the submitter, which holds no ground truth. The score key (<out>.key.json beside --out by default) "
            "names the ground truth; keep it, and score the predictions with `inpaintenv score --manifest <key>`. "
            "A prediction <name>.png may have its per-pixel interval beside it, as <name>_low.png and "
            "<name>_high.png or as <name>_std.png (same encoding; all predictions or none); score reads them."
        ),
    )
    p.add_argument("--protocol", default="rect-v1",
                   help="occlusion protocol (default rect-v1; densify-v1, no hole, with --input scan)")
    p.add_argument("--input", choices=list(INPUT_KINDS), default="map", metavar="KIND",
                   help="what is exported as the input: map (the ground truth with the hole cut, the default) or "
                        "scan (each frame's single LiDAR scan with the hole cut; the ground truth stays the target)"
                        "; or a sparser LiDAR made from the scan: scan-rings32-v1 / scan-rings16-v1 / scan-rings8-v1 "
                        "(every 2nd / 4th / 8th laser ring), scan-points50-v1 / scan-points25-v1 / scan-points10-v1 "
                        "(a seeded share of its points; docs/protocols.md)")
    p.add_argument("--seed", type=int, action="append", metavar="S",
                   help="evaluation seed (default 0; repeatable only with --trusted: each input would show the other "
                        "seeds' holes as measured depth)")
    p.add_argument("--trusted", action="store_true",
                   help="an export for your own method only, never for a submitter: allows several --seed")
    p.add_argument("--holdout", type=float, metavar="FRACTION",
                   help=f"export only the drive-level test split `inpaintenv benchmark` scores (default "
                        f"{SYNTHETIC_HOLDOUT} for the synthetic source, 0 = all frames)")
    p.add_argument("--out", default="submission-inputs", metavar="DIR",
                   help="folder of the export (default submission-inputs)")
    p.add_argument("--key", metavar="PATH",
                   help="where the score key goes (default <out>.key.json beside --out; never inside --out)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace an earlier export in --out (only files it wrote, unchanged) and its score key")
    add_source_options(p)
    add_common_options(p)
    p.set_defaults(func=cmd_export)


def cmd_export(args: argparse.Namespace) -> int:
    """Run ``inpaintenv export``."""
    from ..conventions import check_seeds
    from ..data.synthetic import SyntheticStreets
    from ..masks import get_protocol
    from ..submission.export import check_one_mask_per_frame, export

    seeds = check_seeds(args.seed or [0], "--seed")
    check_one_mask_per_frame(seeds, args.trusted, "--trusted")
    get_protocol(args.protocol)
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise InvalidInputError(f"--out {out} is a file; give a folder for the export")
    dataset = open_source_from_args(args)
    # The benchmark's frames: the same test split by default, so rows of both are comparable.
    holdout = args.holdout
    if holdout is None:
        holdout = SYNTHETIC_HOLDOUT if isinstance(dataset, SyntheticStreets) else 0.0
    if not 0.0 <= holdout < 1.0:
        raise InvalidInputError(f"--holdout must be in [0, 1), got {holdout}")
    if holdout > 0:
        dataset = test_split(dataset, holdout)
    manifest = export(out, dataset, args.protocol, seeds, overwrite=args.overwrite, progress=not args.quiet,
                      trusted=args.trusted, key=args.key)
    n_frames = len(manifest.frames)
    kind = manifest.input_kind
    scans = "" if kind == "map" else ", inputs: scans" + ("" if kind == "scan" else f" ({kind})")
    print(f"exported {len(manifest.items)} input{'s' * (len(manifest.items) != 1)} ({n_frames} "
          f"frame{'s' * (n_frames != 1)} × {len(seeds)} seed{'s' * (len(seeds) != 1)}, protocol "
          f"{manifest.protocol_name}{scans}) to {out}")
    if args.trusted and len(seeds) > 1:
        print("--trusted: each input shows the other seeds' holes; do not give this export to a submitter")
    print(f"each prediction goes to <predictions>/<input's path>, e.g. {manifest.items[0].input}")
    print(f"keep the score key {manifest.path} to yourself (it names the ground truth); give {out} to the submitter")
    print(f"then: inpaintenv score --manifest {manifest.path} --predictions <predictions> --name <method>")
    return 0
