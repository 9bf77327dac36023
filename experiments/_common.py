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


def seeds_option(text: str) -> tuple[int, ...]:
    """A comma-separated list of seeds (argparse ``type``): whole numbers from 0, else ``ArgumentTypeError``."""
    try:
        seeds = tuple(int(v) for v in text.split(","))
    except ValueError:
        seeds = ()
    if not seeds or min(seeds) < 0:
        raise argparse.ArgumentTypeError(f"{text!r}: comma-separated whole numbers from 0")
    return seeds


def numbers_option(text: str) -> tuple[float, ...]:
    """A comma-separated list of finite numbers (argparse ``type``), else ``ArgumentTypeError``."""
    try:
        numbers = tuple(float(v) for v in text.split(","))
    except ValueError:
        numbers = ()
    if not numbers or not all(np.isfinite(numbers)):
        raise argparse.ArgumentTypeError(f"{text!r}: comma-separated finite numbers")
    return numbers


def bin_labels(edges: Sequence[float]) -> list[str]:
    """``<= 1``, ``1-2``, ..., ``> 64``: the bins of ``edges`` (bin ``b`` holds ``edges[b-1] < v <= edges[b]``)."""
    e = [f"{v:g}" for v in edges]
    return [f"<= {e[0]}"] + [f"{a}-{b}" for a, b in zip(e, e[1:])] + [f"> {e[-1]}"]


def pooled(parts: list[tuple]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The parts' rows stacked, frame numbers kept distinct across parts."""
    frames, offset = [], 0
    for _, _, fr in parts:
        frames.append(fr + offset)
        offset += int(fr.max()) + 1
    return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts]), np.concatenate(frames)


def interval_scores(coef: np.ndarray, q: Any, F: np.ndarray, r: np.ndarray, frame: np.ndarray) -> dict[str, float]:
    """Mean over units of coverage, width (low clipped at 0 m) and RMSE cut by the narrowest 80 %
    (``q``: one quantile, or one per pixel)."""
    from estimators.intervals import scale_from
    from inpaintenv.metrics import rejection_curve, sparsification

    half = q * scale_from(coef, F)
    width = half + np.minimum(half, np.exp(F[:, 2]))  # column 2 is log(max(pred, 1 m)): low clipped at 0
    units, unit = np.unique(frame, return_inverse=True)
    n = np.bincount(unit).astype(np.float64)
    sq = r ** 2
    curve = rejection_curve(sq, np.round(width, 3), unit, len(units), (0.8, 1.0))
    # AUSE as pNCNN reports it: RMSE-based, every pixel of the day and task pooled, normalised by the start.
    ause = sparsification(r + 1.0, np.ones_like(r), width, np.ones(r.shape, bool), "pooled", "rmse")["ause"]
    return {"coverage": float(np.mean(np.bincount(unit, r <= half) / n)),
            "width": float(np.mean(np.bincount(unit, width) / n)),
            "cut_80": float(np.nanmean(1.0 - curve[:, 0] / curve[:, 1])), "ause": float(ause)}


def coverage_by_bin(coef: np.ndarray, q: Any, F: np.ndarray, r: np.ndarray, signals: Sequence[str]) -> dict[str, list]:
    """Pixels pooled: ``[coverage, pixels]`` per bin of each variable (``DEFAULT_EDGES``' bins); ``signals``: ``F``'s columns."""
    from estimators.intervals import cell_of, scale_from
    from inpaintenv.values.interval_calibration import DEFAULT_EDGES

    inside = r <= q * scale_from(coef, F)
    out = {}
    for variable, edges in DEFAULT_EDGES.items():
        cells = cell_of({"variable": variable, "edges": edges}, signals, F)
        n = np.bincount(cells, minlength=len(edges) + 1)
        hit = np.bincount(cells, inside, minlength=len(edges) + 1)
        out[f"by_{variable}"] = [[float(h / k) if k else None, int(k)] for h, k in zip(hit, n)]
    return out


def frame_factors(coef: np.ndarray, probe: dict, coverage: float) -> Any:
    """``frames -> factor per row``: each frame's ``coverage`` quantile of its normalised probe residuals
    (``probe``: ``day_residuals`` of probe holes); a frame without a probe pixel takes the median factor."""
    from estimators.intervals import scale_from

    F, r, frame = (np.concatenate([v[i] for v in probe.values()]) for i in range(3))
    normed = r / scale_from(coef, F)
    size = int(frame.max()) + 1
    table = np.full(size, np.nan)
    order = np.argsort(frame, kind="stable")
    bounds = np.searchsorted(frame[order], np.arange(size + 1))
    for f in range(size):
        if bounds[f + 1] > bounds[f]:
            table[f] = np.quantile(normed[order[bounds[f]:bounds[f + 1]]], coverage)
    median = np.nanmedian(table)
    table[np.isnan(table)] = median
    return lambda frames: np.where(frames < size, table[np.minimum(frames, size - 1)], median)


#: :class:`ResidualProbe`'s classical fills beside harmonic: the cheap ones (with ``harmonic-inverse`` and
#: ``ipbasic-scan`` its features take 5.6x harmonic's time).
PROBE_FILLS = ("row-median", "row-far", "window-near", "window-far", "nearest")


class ResidualProbe:
    """A probe, not a release: ``harmonic`` plus a learned per-pixel correction, fitted to truth minus harmonic
    on unmeasured pixels, read from ``residual_features`` (classical ``fills``, the gaps to and depths of the
    nearest measurements, the distance to the nearest one, the measured share around the pixel; those
    ``SparseResidualInpainter`` reads).
    The correction is scikit-learn's ``MLPRegressor`` (``hidden`` units per layer) on standardised features
    (``lodo --estimator mlp``, ``--recipe '{"fills": [...], "hidden": [32, 32]}'``)."""

    def __init__(self, fills: tuple[str, ...] = PROBE_FILLS, hidden: tuple[int, ...] = (128, 128),
                 hole_seeds: tuple[int, ...] = ()) -> None:
        self.fills, self.hidden, self.hole_seeds = tuple(fills), tuple(hidden), tuple(hole_seeds)

    def _inputs(self, scan: np.ndarray, index: int) -> list[np.ndarray]:
        """The scan, then per ``hole_seeds`` seed the scan with rect-v1's hole of that seed cut out (NaN = to fill)."""
        from inpaintenv.data.inputs import method_input  # noqa: PLC0415 - only the probe needs it

        rect = get_protocol("rect-v1")
        holes = [np.zeros(scan.shape, bool)] + [rect.mask(scan.shape, s, index) for s in self.hole_seeds]
        return [method_input(scan, hole, "scan") for hole in holes]

    def fit(self, datasets: list[Any], pixels: int = 4000, seed: int = 0) -> ResidualProbe:
        from sklearn.neural_network import MLPRegressor  # noqa: PLC0415 - only this probe needs them
        from sklearn.pipeline import make_pipeline  # noqa: PLC0415
        from sklearn.preprocessing import StandardScaler  # noqa: PLC0415

        from estimators.candidates import residual_features  # noqa: PLC0415

        rng, X, y = np.random.default_rng(seed), [], []
        for frames in datasets:
            for i in range(len(frames)):
                scan, gt = (a[0] for a in frames.load_pairs([i]))
                for x in self._inputs(scan, i):
                    rows, cols = np.nonzero(np.isnan(x) & (gt > 0))
                    pick = rng.choice(len(rows), min(pixels, len(rows)), replace=False)
                    F, harmonic = residual_features(x, self.fills, (rows[pick], cols[pick]))
                    X.append(F)
                    y.append(gt[rows[pick], cols[pick]] - harmonic)
        self.model_ = make_pipeline(StandardScaler(), MLPRegressor(hidden_layer_sizes=self.hidden, batch_size=1024,
                                                                   max_iter=10, random_state=seed))
        self.model_.fit(np.concatenate(X), np.concatenate(y))
        return self

    def predict(self, x: np.ndarray) -> np.ndarray:
        from estimators.candidates import residual_features  # noqa: PLC0415

        todo = np.isnan(x)
        (F, harmonic), out = residual_features(x, self.fills, todo), x.copy()
        out[todo] = np.maximum(harmonic + self.model_.predict(F), 0.1)
        return out
