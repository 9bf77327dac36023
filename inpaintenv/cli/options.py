"""Options shared by several ``inpaintenv`` subcommands, and the data source they select.

Every subcommand module of :mod:`inpaintenv.cli` imports this one; it imports none of them.

The data source is KITTI when a KITTI root is in effect — ``--kitti-root PATH``, else
``$INPAINTENV_KITTI_ROOT`` when set and non-empty — and the built-in ``SyntheticStreets``
otherwise, or with ``--synthetic``. Options that only mean something for one of the two
(``--split`` and ``--camera`` for KITTI; ``--frame-shape`` and ``--data-seed`` for the
synthetic streets) are refused in one line when the other source is in effect, instead
of being dropped without a word.
"""

from __future__ import annotations

import argparse
import os
import sys
from typing import Any

from ..conventions import check_frame_shape
from ..exceptions import InvalidInputError

__all__ = ["MAX_THREADS", "SYNTHETIC_HOLDOUT", "add_common_options", "add_source_options", "check_source_options",
           "kitti_root_from_args", "open_source_from_args", "test_split", "thread_count"]

#: Read when ``--kitti-root`` is not given (the same variable ``KittiDepth(root=None)`` reads).
KITTI_ROOT_ENV = "INPAINTENV_KITTI_ROOT"
#: KITTI defaults, applied only when a KITTI root is in effect.
DEFAULT_SPLIT, DEFAULT_CAMERA = "train", "image_02"
#: ``--threads`` is at most this many per CPU core of the machine, and may always be
#: up to :data:`MIN_MAX_THREADS`: more threads than that only oversubscribe the cores,
#: and a huge count fails deep in torch ("failed to map segment").
THREADS_PER_CORE, MIN_MAX_THREADS = 4, 64
MAX_THREADS = max(MIN_MAX_THREADS, THREADS_PER_CORE * (os.cpu_count() or 1))
#: Share of drives held out as the test split of the synthetic default source
#: (``benchmark`` scores it, ``export`` writes it).
SYNTHETIC_HOLDOUT = 0.25


def add_source_options(parser: argparse.ArgumentParser) -> None:
    """Options choosing the data source: real KITTI, or the built-in synthetic streets."""
    g = parser.add_argument_group(
        "data source (KITTI with --kitti-root or $INPAINTENV_KITTI_ROOT, else built-in SyntheticStreets)"
    )
    which = g.add_mutually_exclusive_group()
    which.add_argument("--kitti-root", metavar="PATH",
                       help=f"root of a KITTI depth-completion tree (default: ${KITTI_ROOT_ENV} when set)")
    which.add_argument("--synthetic", action="store_true",
                       help=f"use the built-in SyntheticStreets even when ${KITTI_ROOT_ENV} is set")
    g.add_argument("--split", help="KITTI split: train, val or val_selection, or several joined by commas, "
                   "e.g. train,val (default train; KITTI only)")
    g.add_argument("--camera", choices=["image_02", "image_03", "both"],
                   help="KITTI camera (default image_02; KITTI only)")
    g.add_argument(
        "--kind", default="groundtruth", choices=["groundtruth", "velodyne_raw", "dense"],
        help="the depth maps used as ground truth (what is scored against, or trained on): groundtruth "
             "(accumulated scans, the default) or velodyne_raw (one LiDAR scan), of KITTI or simulated by "
             "SyntheticStreets; dense: synthetic only",
    )
    g.add_argument("--drives", nargs="+", metavar="DRIVE", help="keep only these drives")
    g.add_argument("--exclude-drives", nargs="+", metavar="DRIVE",
                   help="drop these drives (e.g. the ones a model was trained on)")
    g.add_argument("--n-frames", type=int, metavar="N", help="use only the first N frames")
    g.add_argument(
        "--frame-shape", type=int, nargs=2, metavar=("H", "W"),
        help="synthetic frame size (default 352 1216, KITTI's crop; at least 8 8, at most 50 million pixels; "
             "synthetic only)",
    )
    g.add_argument("--data-seed", type=int, help="seed of the synthetic streets (default 0; synthetic only)")


def add_common_options(parser: argparse.ArgumentParser) -> None:
    """Options every subcommand takes."""
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bars")


def kitti_root_from_args(args: argparse.Namespace) -> tuple[str | None, str]:
    """The KITTI root in effect and where it comes from.

    Returns
    -------
    (root, origin)
        ``root`` is ``--kitti-root``, else ``$INPAINTENV_KITTI_ROOT`` (unless
        ``--synthetic``), else None (the synthetic source); ``origin`` says which
        (``"--kitti-root"``, ``"$INPAINTENV_KITTI_ROOT"`` or ``"--synthetic"`` / ``""``).

    Raises
    ------
    ValueError
        ``--kitti-root ""``: an empty path would be read as the current folder.
    """
    if args.kitti_root is not None:
        if not str(args.kitti_root).strip():
            raise InvalidInputError("--kitti-root is empty; give the folder holding train/ and val/ (or leave the option out)")
        return args.kitti_root, "--kitti-root"
    if getattr(args, "synthetic", False):
        return None, "--synthetic"
    env = os.environ.get(KITTI_ROOT_ENV, "").strip()
    return (env, f"${KITTI_ROOT_ENV}") if env else (None, "")


def check_source_options(args: argparse.Namespace) -> str | None:
    """Refuse the options that do not apply to the source in effect; return its KITTI root or None.

    Cheap (no file is read), so subcommands call it before any long work.

    Raises
    ------
    ValueError
        One line naming the option, e.g. ``--split`` without a KITTI root.
    """
    root, origin = kitti_root_from_args(args)
    if root is None:
        given = [flag for flag, value in (("--split", args.split), ("--camera", args.camera)) if value is not None]
        if given:
            why = "--synthetic is given" if origin == "--synthetic" else (
                f"no KITTI root is in effect (give --kitti-root PATH or set {KITTI_ROOT_ENV})")
            raise InvalidInputError(f"{' and '.join(given)} applies to KITTI data only, but {why}")
    else:
        given = [flag for flag, value in (("--frame-shape", args.frame_shape), ("--data-seed", args.data_seed))
                 if value is not None]
        if given:
            hint = " (add --synthetic for the built-in data)" if origin.startswith("$") else ""
            raise InvalidInputError(
                f"{' and '.join(given)} applies to the synthetic source only, but KITTI is in effect "
                f"from {origin} {root}{hint}; KITTI frames are cropped to 352x1216"
            )
        if args.kind == "dense":
            raise InvalidInputError(f"--kind dense exists only for the synthetic source (KITTI from {origin} has no dense "
                             "truth)")
    if args.n_frames is not None and args.n_frames < 1:
        raise InvalidInputError(f"--n-frames must be >= 1, got {args.n_frames}")
    if root is None:
        from ..data.synthetic import MAX_SYNTHETIC_FRAMES

        if args.n_frames is not None and args.n_frames > MAX_SYNTHETIC_FRAMES:
            raise InvalidInputError(f"--n-frames {args.n_frames} is more than the {MAX_SYNTHETIC_FRAMES:,} frames the "
                             "synthetic source may have (MAX_SYNTHETIC_FRAMES)")
        if args.frame_shape is not None:
            check_frame_shape(args.frame_shape, "--frame-shape")
    return root


def thread_count(text: str) -> int:
    """``--threads N`` as argparse reads it: an integer of at most ``MAX_THREADS``, else one line naming the limit.

    The lower bound (1) is the estimator's own check of ``num_threads``, which names the parameter.

    Raises
    ------
    argparse.ArgumentTypeError
        For a count above the limit (``100000`` threads made torch fail with "failed to
        map segment") or text that is not a whole number.
    """
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a whole number of threads, got {text!r}") from None
    if n > MAX_THREADS:
        raise argparse.ArgumentTypeError(f"must be at most {MAX_THREADS} (MAX_THREADS: {THREADS_PER_CORE} per CPU "
                                         f"core of this machine, at least {MIN_MAX_THREADS}), got {n}")
    return n


def open_source_from_args(args: argparse.Namespace) -> Any:
    """Build the data source selected by :func:`add_source_options`' options.

    ``KittiDepth`` (split ``--split``, default train) when a KITTI root is in effect (see
    :func:`kitti_root_from_args`), otherwise the built-in ``SyntheticStreets``
    (``--n-frames`` frames, 64 by default; ``--frame-shape`` sets their size). A root
    taken from ``$INPAINTENV_KITTI_ROOT`` is announced on stderr unless ``--quiet``.
    """
    from ..data import SyntheticStreets, open_source, select_drives
    from ..data.sources import DEFAULT_SYNTHETIC_FRAMES

    root = check_source_options(args)
    _, origin = kitti_root_from_args(args)
    if root is not None and origin.startswith("$") and not getattr(args, "quiet", False):
        print(f"data: KITTI at {root} (from {origin}; --synthetic for the built-in data)", file=sys.stderr)
    seed = 0 if args.data_seed is None else args.data_seed
    if root is None and args.frame_shape:
        return select_drives(
            SyntheticStreets(
                n=args.n_frames or DEFAULT_SYNTHETIC_FRAMES, seed=seed, kind=args.kind,
                frame_shape=tuple(args.frame_shape), input=getattr(args, "input", "map"),
            ),
            args.drives, args.exclude_drives,
        )
    return open_source(
        root, split=args.split or DEFAULT_SPLIT, kind=args.kind, n_frames=args.n_frames,
        seed=seed, camera=args.camera or DEFAULT_CAMERA, drives=args.drives,
        exclude_drives=args.exclude_drives, input=getattr(args, "input", "map"),  # --input where a command has it
    )


def test_split(dataset: Any, holdout: float) -> Any:
    """The drive-level test split of ``dataset`` holding ``holdout`` of its drives."""
    from ..data import split_by_drive

    try:
        return split_by_drive(dataset, test_size=holdout, seed=0)[1]
    except ValueError as exc:
        raise InvalidInputError(f"--holdout {holdout:g}: {exc}; pass --holdout 0 to score all frames") from None
