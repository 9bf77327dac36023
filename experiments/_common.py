"""What two kept experiment scripts share: the selection frames and the KITTI root from the environment.

``pretrained_selection.py`` and ``selection_scores.py`` train and score on the selection
frames of ``kitti-mixed-v1`` (drive 9001, frames 56-67, seed 0); ``baselines_table.py`` and
``tune_classical.py`` read the KITTI root from ``$INPAINTENV_KITTI_ROOT``. Only the package's
public API is used here.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

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
