"""What the experiment scripts share: the selection frames, the KITTI root from the environment, subcommands.

``selection_frames.py`` trains and scores on the selection frames of ``kitti-mixed-v1``
(drive 9001, frames 56-67, seed 0); ``classical_baselines.py`` and ``scan_lodo.py`` read the
KITTI root from ``$INPAINTENV_KITTI_ROOT``; a script of several commands dispatches them with
:func:`run_command`; :func:`edges_option` reads a ``--condition-edges`` option, :func:`bin_labels` names bins. Only the package's
public API is used here.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from inpaintenv.masks import get_protocol
from inpaintenv.metrics import aggregate, frame_metrics

#: The drive the one-drive releases trained and were selected on.
SELECTION_DRIVE = "2011_09_26_drive_9001_sync"
#: Frames 0..N_TRAIN-1 of SELECTION_DRIVE (ids 5-60) train; the rest (ids 61-72) select.
N_TRAIN = 56
#: The classical methods' defaults were only ever compared on this drive.
TUNING_DRIVE = SELECTION_DRIVE


def sel_scores(predict: Callable[[np.ndarray], np.ndarray], sel: np.ndarray, protocol: str = "rect-v1") -> dict:
    """Hole/all RMSE of ``predict`` (batch of corrupted frames -> depth) on ``sel`` (seed 0).

    Parameters
    ----------
    predict : callable
        ``(N, H, W)`` float32 frames with NaN in the holes -> ``(N, H, W)`` filled depth.
    sel : ndarray of shape (N, H, W)
        Ground-truth frames (metres, 0 = no data).
    protocol : str, default "rect-v1"
        Occlusion protocol of the masks (frame ``i`` gets mask ``i`` of seed 0).

    Returns
    -------
    dict
        :func:`inpaintenv.metrics.aggregate` of the per-frame metrics (``hole_rmse``, ``all_rmse``, ...).
    """
    holes = get_protocol(protocol).masks(sel.shape[1:], 0, range(len(sel)))
    x = np.where(holes, np.nan, sel).astype(np.float32)
    return aggregate(frame_metrics(predict(x), sel, holes))


def default_root() -> Path | None:
    """``$INPAINTENV_KITTI_ROOT`` (None when unset: then ``--root`` is required)."""
    env = os.environ.get("INPAINTENV_KITTI_ROOT")
    return Path(env) if env else None


def run_command(script: str, commands: dict[str, Callable[[list[str]], Any]], argv: list[str] | None) -> Any:
    """Run ``commands[argv[0]]`` on the rest of ``argv`` (``sys.argv[1:]`` when None).

    Parameters
    ----------
    script : str
        The script's file name, for the usage line.
    commands : dict
        Command name -> function of the remaining arguments.
    argv : list of str or None
        The command line after the script's name.

    Returns
    -------
    object
        What the command returns.
    """
    argv = sys.argv[1:] if argv is None else list(argv)
    usage = f"usage: python experiments/{script} {{{','.join(commands)}}} [options]  (COMMAND --help: its options)"
    if argv and argv[0] in ("-h", "--help"):
        print(usage)
        raise SystemExit(0)
    if not argv or argv[0] not in commands:
        raise SystemExit(f"{usage}\n{script}: " + (f"no command {argv[0]!r}" if argv else "no command given"))
    return commands[argv[0]](argv[1:])


def exit_status(result: Any) -> int:
    """A command's result as the process's exit status: an int as it is, anything else (a table) 0."""
    return result if isinstance(result, int) and not isinstance(result, bool) else 0


def edges_option(text: str) -> tuple[float, ...]:
    """A ``--condition-edges`` value (argparse ``type``): comma-separated bin edges, as ``check_edges`` takes them.

    Parameters
    ----------
    text : str
        ``"E1,E2,..."``: increasing positive finite numbers.

    Returns
    -------
    tuple of float
        The edges.

    Raises
    ------
    argparse.ArgumentTypeError
        Anything else (argparse then names the option and exits with status 2).
    """
    from estimators.intervals import check_edges

    try:
        return check_edges([float(v) for v in text.split(",")])
    except ValueError as err:  # float() or check_edges (an InvalidInputError is a ValueError)
        raise argparse.ArgumentTypeError(f"{text!r}: comma-separated increasing positive finite numbers") from err


def bin_labels(edges: Sequence[float]) -> list[str]:
    """``<= 1``, ``1-2``, ..., ``> 64``: the bins of ``edges`` (bin ``b`` holds ``edges[b-1] < v <= edges[b]``)."""
    e = [f"{v:g}" for v in edges]
    return [f"<= {e[0]}"] + [f"{a}-{b}" for a, b in zip(e, e[1:])] + [f"> {e[-1]}"]
