"""IP-Basic against its published code, on KITTI's official frames that have a single scan.

Usage::

    python perf/published_ipbasic.py --ip-basic <ip_basic clone> --kitti-root <KITTI root>

``--ip-basic`` is a checkout of https://github.com/kujason/ip_basic (Ku et al., CRV 2018),
used unchanged and imported by path: its ``ip_basic/depth_map_utils.py`` needs only NumPy and
OpenCV. The frames are every official frame with a scan: ``depth_selection/val_selection_cropped``
(``velodyne_raw`` → ``groundtruth_depth``) and ``train/<--drive>/proj_depth/velodyne_raw`` of
both cameras → ``proj_depth/groundtruth`` (by default drive 2011_09_26_drive_0001, the slice's
drive of official maps).

Every method fills the scan (0 = no measurement; this package's methods get NaN there).
Published modes: ``fill_in_fast`` as in the paper's KITTI test result (``extrapolate=True``,
``blur_type='gaussian'``, the demo's default), as the README recommends (``extrapolate=False``,
``'bilateral'``) and ``fill_in_multiscale`` (``extrapolate=False``, ``'bilateral'``). A
prediction left at 0 m is filled by the KITTI devkit's background interpolation before it is
scored, as the devkit does. Scores per frame, then the mean over frames: RMSE and MAE in mm
on every ground-truth pixel (the devkit's set, truth > 0) and RMSE on the unmeasured ones
(truth > 0 and scan == 0); the median fill time in ms per frame (one untimed warm-up call per
method); for this package's rows, the ratio of mean RMSE to the published mode named in
``vs``, with a paired percentile-bootstrap 95 % interval over frames. One Markdown table per
frame set and one over all frames (each set's frames scored once); "left empty" is the share
of pixels a method leaves at 0 m. Under each table: the scan's own error against the truth
where both exist, and on how many pixels each configuration of ``IPBasicInpainter`` that
mirrors a published mode differs from it by more than 0.1 mm.
"""

from __future__ import annotations

import argparse
import importlib.util
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from types import ModuleType
from typing import NamedTuple

import numpy as np

from estimators.classical import IPBasicInpainter
from inpaintenv.data import read_depth_png
from inpaintenv.data.kitti import bottom_center_crop
from inpaintenv.exceptions import InvalidInputError
from inpaintenv.metrics import interpolate_background
from inpaintenv.methods.registry import make_method
from inpaintenv.report.stats import FEW_FRAMES, bootstrap_ratio_ci

#: The slice's drive of official maps with scans.
DEFAULT_DRIVE = "2011_09_26_drive_0001_sync"
CAMERAS = ("image_02", "image_03")
#: The published mode this package's rows are compared with unless they name another.
PAPER = "published fast, paper (extrapolate, gaussian)"
RECOMMENDED = "published fast, README (bilateral)"
MULTISCALE = "published multiscale (bilateral)"
#: This package's classical fills reported beside IP-Basic.
CLASSICAL_ROWS = ("harmonic", "nearest", "scanline")

Fill = Callable[[np.ndarray], np.ndarray]


class Pair(NamedTuple):
    """One official frame: its single scan and its ground truth."""

    frame_id: str
    scan: Path
    truth: Path


class Method(NamedTuple):
    """A named fill of a scan (0 = no data), the published mode its ratio is taken against, and
    whether it is configured to mirror that mode (then its pixels are compared too)."""

    name: str
    fill: Fill
    reference: str | None = None
    mirror: bool = False


def val_selection_pairs(root: Path) -> list[Pair]:
    """The frames of ``depth_selection/val_selection_cropped`` with both a scan and a truth."""
    folder = root / "depth_selection" / "val_selection_cropped"
    pairs = []
    for scan in sorted((folder / "velodyne_raw").glob("*.png")):
        truth = folder / "groundtruth_depth" / scan.name.replace("_velodyne_raw_", "_groundtruth_depth_")
        if truth.is_file():
            pairs.append(Pair(f"val_selection/{scan.stem}", scan, truth))
    return pairs


def drive_pairs(root: Path, drive: str) -> list[Pair]:
    """The frames of ``train/<drive>`` (both cameras) with both a scan and a truth."""
    folder = root / "train" / drive / "proj_depth"
    pairs = []
    for camera in CAMERAS:
        for scan in sorted((folder / "velodyne_raw" / camera).glob("*.png")):
            truth = folder / "groundtruth" / camera / scan.name
            if truth.is_file():
                pairs.append(Pair(f"{drive}/{camera}/{scan.stem}", scan, truth))
    return pairs


def official_pairs(root: Path, drive: str = DEFAULT_DRIVE) -> dict[str, list[Pair]]:
    """The frame sets by name; a set without frames is left out."""
    sets = {"val_selection_cropped": val_selection_pairs(root), drive: drive_pairs(root, drive)}
    return {name: pairs for name, pairs in sets.items() if pairs}


def load_published(clone: Path) -> ModuleType:
    """Import ``ip_basic/depth_map_utils.py`` of the clone by path (nothing else of it runs)."""
    path = clone / "ip_basic" / "depth_map_utils.py"
    if not path.is_file():
        raise FileNotFoundError(f"{path} not found: --ip-basic must be a checkout of kujason/ip_basic")
    spec = importlib.util.spec_from_file_location("published_ip_basic_depth_map_utils", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def published_methods(module: ModuleType) -> list[Method]:
    """The published modes; each gets a copy, since the published code fills in place."""
    fast = module.fill_in_fast
    methods = [
        Method(PAPER, lambda s: fast(s.copy(), extrapolate=True, blur_type="gaussian")),
        Method(RECOMMENDED, lambda s: fast(s.copy(), extrapolate=False, blur_type="bilateral")),
    ]
    if hasattr(module, "fill_in_multiscale"):
        multi = module.fill_in_multiscale
        methods.append(Method(MULTISCALE, lambda s: multi(s.copy(), extrapolate=False, blur_type="bilateral")[0]))
    return methods


def _package_fill(estimator: object) -> Fill:
    """``estimator.predict`` on the scan with every unmeasured pixel to fill (NaN)."""
    return lambda s: estimator.predict(np.where(s > 0, s, np.nan).astype(np.float32))


def package_methods() -> list[Method]:
    """``ipbasic`` as registered, one step at a time towards each published fast mode, its
    strongest setting on scans, and the other classical fills."""
    unkept = IPBasicInpainter(keep_observed=False)
    as_paper = IPBasicInpainter(extrapolate=True, large_hole_kernel=None, keep_observed=False)
    as_readme = IPBasicInpainter(large_hole_kernel=None, blur="bilateral", keep_observed=False)
    no_large = IPBasicInpainter(large_hole_kernel=None, keep_observed=False)
    methods = [
        Method("ipbasic", _package_fill(make_method("ipbasic")), PAPER),
        Method(f"`{unkept!r}`", _package_fill(unkept), PAPER),
        Method(f"`{as_paper!r}`", _package_fill(as_paper), PAPER, mirror=True),
        Method(f"`{as_readme!r}`", _package_fill(as_readme), RECOMMENDED, mirror=True),
        Method(f"`{no_large!r}`", _package_fill(no_large), PAPER),
    ]
    methods += [Method(name, _package_fill(make_method(name)), PAPER) for name in CLASSICAL_ROWS]
    return methods


def read_pair(pair: Pair, crop: tuple[int, int] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(scan, truth)`` in metres, both cropped bottom-centre to ``crop`` when given."""
    scan, truth = read_depth_png(pair.scan), read_depth_png(pair.truth)
    if scan.shape != truth.shape:
        raise InvalidInputError(f"{pair.frame_id}: scan {scan.shape} and truth {truth.shape} differ in size")
    if crop is not None:
        scan = bottom_center_crop(scan, crop, name=str(pair.scan))
        truth = bottom_center_crop(truth, crop, name=str(pair.truth))
    return scan, truth


def frame_scores(pred: np.ndarray, truth: np.ndarray, scan: np.ndarray) -> dict[str, float]:
    """RMSE and MAE (mm) on ``truth > 0``, RMSE (mm) on ``truth > 0 & scan == 0``, and the
    share (%) of pixels left at 0 m, which the devkit's background interpolation fills first.
    """
    empty = 100.0 * float(np.mean(~(pred > 0)))
    pred = interpolate_background(pred).astype(np.float64)
    err = pred - truth.astype(np.float64)
    scored = truth > 0
    unmeasured = scored & ~(scan > 0)
    return {
        "rmse": 1000.0 * float(np.sqrt(np.mean(err[scored] ** 2))),
        "mae": 1000.0 * float(np.mean(np.abs(err[scored]))),
        "unmeasured_rmse": 1000.0 * float(np.sqrt(np.mean(err[unmeasured] ** 2))),
        "empty": empty,
    }


def agreement(ours: Method, published: Method, frames: Sequence[tuple[np.ndarray, np.ndarray]]) -> tuple[int, int]:
    """Pixels where two fills differ by more than 0.1 mm, and all pixels, over ``frames``."""
    differ = sum(int(np.sum(np.abs(ours.fill(scan) - published.fill(scan)) > 1e-4)) for scan, _ in frames)
    return differ, sum(scan.size for scan, _ in frames)


def scan_error(frames: Sequence[tuple[np.ndarray, np.ndarray]]) -> tuple[float, float]:
    """The scan against the truth where both exist: mean RMSE (mm) and share (%) of truth pixels."""
    rmse, share = [], []
    for scan, truth in frames:
        both = (scan > 0) & (truth > 0)
        err = scan[both].astype(np.float64) - truth[both]
        rmse.append(1000.0 * np.sqrt(np.mean(err**2)) if both.any() else np.nan)
        share.append(100.0 * both.sum() / max(int(np.sum(truth > 0)), 1))
    return float(np.nanmean(rmse)), float(np.mean(share))


def score_methods(
    methods: Sequence[Method], frames: Sequence[tuple[np.ndarray, np.ndarray]]
) -> dict[str, dict[str, np.ndarray]]:
    """Per-frame scores and fill times (ms) of every method on ``(scan, truth)`` frames."""
    results = {}
    for method in methods:
        method.fill(frames[0][0])  # warm-up: imports, OpenCV's thread pool
        rows, times = [], []
        for scan, truth in frames:
            start = time.perf_counter()
            pred = method.fill(scan)
            times.append(1000.0 * (time.perf_counter() - start))
            rows.append(frame_scores(np.asarray(pred, np.float32), truth, scan))
        results[method.name] = {key: np.array([r[key] for r in rows]) for key in rows[0]}
        results[method.name]["ms"] = np.array(times)
    return results


def concatenate(results: Sequence[dict[str, dict[str, np.ndarray]]]) -> dict[str, dict[str, np.ndarray]]:
    """The per-frame results of several frame sets as one set (same methods in each)."""
    return {
        name: {key: np.concatenate([r[name][key] for r in results]) for key in results[0][name]}
        for name in results[0]
    }


def _ratio_cell(ours: np.ndarray, published: np.ndarray) -> str:
    ratio, low, high = bootstrap_ratio_ci(ours, published)
    if not np.isfinite(low):
        return f"{ratio:.3f}"
    rough = " (rough)" if len(ours) < FEW_FRAMES else ""
    return f"{ratio:.3f} [{low:.3f}, {high:.3f}]{rough}"


def summary_rows(methods: Sequence[Method], results: dict[str, dict[str, np.ndarray]]) -> list[dict[str, str]]:
    """One table row per method: means over frames, median ms, ratios to its reference."""
    rows = []
    for method in methods:
        r = results[method.name]
        row = {
            "method": method.name, "vs": method.reference or "",
            "rmse": f"{r['rmse'].mean():.1f}", "mae": f"{r['mae'].mean():.1f}",
            "unmeasured_rmse": f"{r['unmeasured_rmse'].mean():.1f}", "empty": f"{r['empty'].mean():.1f}",
            "ms": f"{np.median(r['ms']):.1f}",
            "rmse_ratio": "", "unmeasured_ratio": "",
        }
        if method.reference is not None:
            ref = results[method.reference]
            row["rmse_ratio"] = _ratio_cell(r["rmse"], ref["rmse"])
            row["unmeasured_ratio"] = _ratio_cell(r["unmeasured_rmse"], ref["unmeasured_rmse"])
        rows.append(row)
    return rows


def markdown_table(rows: Sequence[dict[str, str]]) -> str:
    """The rows of :func:`summary_rows` as a Markdown table."""
    lines = [
        "| method | vs | RMSE (mm) | MAE (mm) | unmeasured RMSE (mm) | left empty (%) | ms/frame "
        "| RMSE ratio [95 %] | unmeasured RMSE ratio [95 %] |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    keys = ("method", "vs", "rmse", "mae", "unmeasured_rmse", "empty", "ms", "rmse_ratio", "unmeasured_ratio")
    lines += ["| " + " | ".join(row[k] for k in keys) + " |" for row in rows]
    return "\n".join(lines)


def notes(methods: Sequence[Method], frames: Sequence[tuple[np.ndarray, np.ndarray]]) -> str:
    """Lines under a table: the scan's own error, and where each mirroring row differs per pixel."""
    rmse, share = scan_error(frames)
    lines = [f"\nThe scan against the truth where both exist: RMSE {rmse:.1f} mm, on {share:.1f} % of the truth pixels."]
    by_name = {m.name: m for m in methods}
    for method in methods:
        if method.mirror and method.reference in by_name:
            differ, total = agreement(method, by_name[method.reference], frames)
            lines.append(f"{method.name} and {method.reference} differ by more than 0.1 mm on "
                         f"{differ} of {total} pixels ({100.0 * differ / total:.3g} %).")
    return "\n".join(lines)


def _parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--ip-basic", type=Path, required=True, help="checkout of kujason/ip_basic")
    parser.add_argument("--kitti-root", type=Path, required=True, help="KITTI depth-completion root")
    parser.add_argument("--drive", default=DEFAULT_DRIVE, help="train drive of official maps with scans")
    parser.add_argument("--crop", type=int, nargs=2, metavar=("H", "W"), default=None,
                        help="bottom-centre crop of scan and truth before filling (default: none)")
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> dict[str, list[dict[str, str]]]:
    """Run the comparison, print the tables and return their rows by frame set."""
    args = _parse_args(argv)
    methods = published_methods(load_published(args.ip_basic)) + package_methods()
    sets = official_pairs(args.kitti_root, args.drive)
    if not sets:
        raise SystemExit(f"no official frame with a scan and a truth under {args.kitti_root}")
    crop = tuple(args.crop) if args.crop else None
    frames = {name: [read_pair(p, crop) for p in pairs] for name, pairs in sets.items()}
    results = {name: score_methods(methods, set_frames) for name, set_frames in frames.items()}
    if len(results) > 1:
        results["all frames"] = concatenate(list(results.values()))
        frames["all frames"] = [f for set_frames in list(frames.values()) for f in set_frames]
    tables = {}
    for name, result in results.items():
        print(f"\n### {name} ({len(frames[name])} frames, crop {crop or 'none'})\n")
        tables[name] = summary_rows(methods, result)
        print(markdown_table(tables[name]))
        print(notes(methods, frames[name]), flush=True)
    return tables


if __name__ == "__main__":
    main()
