"""Leave-one-day-out check of ConformalIntervalInpainter's 90 % intervals on real KITTI.

For each recording day D of the train split: calibrate the wrapper around a fill that
never saw any drive (a classical method) on the other days' drives, then score D's drives
with ``inpaintenv.evaluate.evaluate(wrapper, ..., intervals=C)``; then the same with drive
2011_09_26_drive_0001_sync (official maps) left out. That drive calibrates no fold, as it
calibrates no shipped interval (``interval_calibration.py calibrate``): its frames are reported. Printed per fold: coverage of the
interval in the hole, mean width, hole RMSE, the RMSE when the most confident 80 % are
kept (and the share cut), and the border baseline (the 80 % nearest the hole border); then
the error-rejection curve per fold (90 / 80 / 50 % kept, its AUC). Each fold's row also gives the
per-image RMSE AUSE (ranked by interval width, metres) and the AUCE (reliability diagram at 50-95 %). Columns are the mean over
the fold's frames of the per-frame values, as in the benchmark; coverage and cut carry their
standard error over those frames (how far other frames and masks of the same drives could
move the mean; drives vary more, see ``interval_split_spread.py``). Drives the base was trained
on (its ``training_drives_``) are left out of both calibration and scoring, so a release
trained on a few drives (``--method kitti-mixed-v1 --protocol mixed-v1``) is checked too.

    python perf/interval_lodo.py --kitti-root /path/to/kitti [--frames-per-drive 6]

``--checkpoint FOLD=PATH`` (repeatable) wraps a learned fold model instead of ``--method``
in the fold FOLD (``day-2011_09_26``, ..., ``drive-0001``): the only honest way to
calibrate a learned model, whose calibration drives it must never have seen. It is then
calibrated on the fold's left-in drives the model's ``training_drives_`` does not name, so
the model must have been trained with a calibration day left out as well.

``--input scan`` checks a fill of a single LiDAR scan (``--method harmonic-ipbasic``, the scan
default) on the rebuilt drives' scans: calibrated with ``--protocol`` (``densify-v1`` by default)
on the other days' rebuilt drives (never on drive 0001, val or val_selection, the official
frames), then scored on the left-out day under each ``--score-protocol`` (default ``densify-v1``
and ``rect-v1``: its rectangles cut out of the scan, ``--seed`` repeatable). The scored pixels
are each task's, as ``evaluate --interval-coverage`` scores them: every pixel the scan did not
measure (densify-v1), the hole (rect-v1); the columns named ``hole`` are on those pixels.
``--protocol densify-v1+rect-v1`` calibrates on both tasks pooled. The official frames are scored as a check: drive 0001's and
val_selection's scans, with the interval calibrated on every rebuilt drive.

    python perf/interval_lodo.py --kitti-root /path/to/kitti --input scan --method harmonic-ipbasic --spread-method harmonic --frames-per-drive 0
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np


OFFICIAL = "2011_09_26_drive_0001_sync"
COLUMNS = ("hole_coverage", "hole_interval_width", "hole_rmse", "rmse_keep_90", "rmse_keep_80", "rmse_keep_50",
           "rmse_cut_80", "rejection_auc", "border_rmse_keep_80", "ause_rmse", "aurg_rmse", "auce")


def folds(drives: list[str]) -> list[tuple[str, list[str], list[str]]]:
    """``(name, calibration drives, scored drives)``: each day left out, then drive 0001 (calibrating none)."""
    days = sorted({d[:10] for d in drives})
    out = [(f"day-{day}", [d for d in drives if d[:10] != day and d != OFFICIAL], [d for d in drives if d[:10] == day])
           for day in days]
    if OFFICIAL in drives:
        out.append(("drive-0001", [d for d in drives if d != OFFICIAL], [OFFICIAL]))
    return out


def standard_error(values: list[float]) -> float:
    """Standard error of the mean of the finite ``values`` (NaN for fewer than two)."""
    v = np.asarray(values, dtype=np.float64)
    v = v[np.isfinite(v)]
    return float(v.std(ddof=1) / np.sqrt(v.size)) if v.size > 1 else float("nan")


def scan_rows(wrapper: Any, test: Any, protocol: str, coverage: float, seeds: list[int]) -> list[dict[str, float]]:
    """Per (seed, frame) of a scan dataset: ``evaluate``'s interval columns and the RMSE of the task.

    The task's pixels, as the benchmark scores them: under densify-v1 every pixel the scan did
    not measure (``unmeasured_rmse``), under a hole protocol the hole cut out of the scan.
    """
    from inpaintenv.evaluate import evaluate
    from inpaintenv.masks import get_protocol

    task = get_protocol(protocol).task
    rows = evaluate(wrapper, test, protocol=protocol, seeds=seeds, intervals=coverage, progress=False,
                    name="conformal").rows
    return [{**r, "hole_rmse": r[f"{task}_rmse"]} for r in rows]


def summary(rows: list[dict[str, float]]) -> dict[str, float]:
    """The mean over frames of each column, and the standard errors of coverage and cut."""
    row = {c: float(np.nanmean([r[c] for r in rows])) for c in COLUMNS}
    row.update({f"{c}_se": standard_error([r[c] for r in rows]) for c in ("hole_coverage", "rmse_cut_80")})
    # Per frame, then the mean: the same reading as rmse_cut_80 (the benchmark's per-frame column).
    row["border_cut_80"] = float(np.nanmean([1 - r["border_rmse_keep_80"] / r["hole_rmse"] for r in rows]))
    return row


def run_fold(base: Any, cal: Any, test: Any, args: argparse.Namespace) -> list[dict[str, Any]]:
    """Calibrate around ``base`` on ``cal``; one row per scored protocol on ``test``."""
    from estimators.intervals import ConformalIntervalInpainter
    from inpaintenv.evaluate import evaluate

    start = time.perf_counter()
    wrapper = ConformalIntervalInpainter(base, coverage=args.coverage, signals=tuple(args.signals),
                                         spread_method=args.spread_method, protocol=args.protocol,
                                         weighting=args.weighting).fit(cal)
    out = []
    for protocol in args.score_protocol:
        if args.input == "scan":
            rows = scan_rows(wrapper, test, protocol, args.coverage,
                             args.seed if protocol != "densify-v1" else [0])
        else:
            rows = evaluate(wrapper, test, protocol=protocol, intervals=args.coverage, progress=False,
                            name="conformal").rows
        row = summary(rows)
        row.update(protocol=protocol, n_frames=len(test), n_cal_pixels=wrapper.calibration_["n_pixels"],
                   n_cal_drives=len(wrapper.calibration_["drives"]), seconds=time.perf_counter() - start)
        out.append(row)
    return out


def scan_folds(dataset: Any, root: str) -> list[tuple[str, list[str], Any, list[str]]]:
    """``(name, calibration drives, scored source, scored drives)`` on scans: each day of the
    rebuilt drives left out, then the official frames (drive 0001, val_selection), only scored,
    with every rebuilt drive calibrating."""
    from inpaintenv.data import KittiDepth

    drives = sorted({str(g) for g in dataset.groups})
    rebuilt = [d for d in drives if d != OFFICIAL]
    out = [(name, cal, dataset, test) for name, cal, test in folds(rebuilt)]
    if OFFICIAL in drives:
        out.append(("drive-0001", rebuilt, dataset, [OFFICIAL]))
    try:
        selection = KittiDepth(root, split="val_selection", camera="both", input="scan")
    except (FileNotFoundError, ValueError):
        return out  # a copy of KITTI without depth_selection/
    out.append(("val_selection", rebuilt, selection, sorted({str(g) for g in selection.groups})))
    return out


def print_row(row: dict[str, Any]) -> None:
    print(f"| {row['fold']} | {row['protocol']} | {row['n_frames']} | {row['n_cal_drives']} / {row['n_cal_pixels']} | "
          f"{row['hole_coverage']:.3f} ± {row['hole_coverage_se']:.3f} | {row['hole_interval_width']:.2f} | "
          f"{row['hole_rmse']:.2f} | {row['rmse_keep_80']:.2f} ({row['rmse_cut_80']:.1%} ± {row['rmse_cut_80_se']:.1%}) | "
          f"{row['border_rmse_keep_80']:.2f} ({row['border_cut_80']:.0%}) | {row['ause_rmse']:.3f} | "
          f"{row['auce']:.3f} |", flush=True)


def main(argv: list[str] | None = None) -> list[dict[str, Any]]:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--kitti-root", required=True)
    parser.add_argument("--method", default="scanline", help="registered fill to wrap (never saw any drive)")
    parser.add_argument("--checkpoint", action="append", default=[], metavar="FOLD=PATH",
                        help="a learned fold model trained without FOLD's drives (day-2011_09_26, ..., drive-0001)")
    parser.add_argument("--spread-method", default="harmonic")
    parser.add_argument("--signals", nargs="*", default=["border", "depth", "spread"])
    parser.add_argument("--coverage", type=float, default=0.9)
    parser.add_argument("--protocol", help="masks protocol of the calibration (default rect-v1 on maps, densify-v1 "
                        "on scans)")
    parser.add_argument("--score-protocol", action="append", default=[],
                        help="a protocol scored (repeatable; default --protocol on maps, densify-v1 and rect-v1 on scans)")
    parser.add_argument("--input", choices=("map", "scan"), default="map",
                        help="the input the method fills: a map with holes, or a single scan (rebuilt drives' scans)")
    parser.add_argument("--seed", type=int, action="append", default=None,
                        help="rect-v1 seed scored on scans (repeatable; default 0)")
    parser.add_argument("--weighting", default="frame", choices=("frame", "pixel"),
                        help="how calibration pixels weigh in the quantile (ConformalIntervalInpainter)")
    parser.add_argument("--frames-per-drive", type=int, default=6, help="0 = every frame")
    parser.add_argument("--json", help="also write the rows here")
    args = parser.parse_args(argv)

    from inpaintenv.data import KittiDepth, spaced_per_drive
    from inpaintenv.methods.registry import make_method

    args.protocol = args.protocol or ("densify-v1" if args.input == "scan" else "rect-v1")
    args.seed = args.seed or [0]
    args.score_protocol = args.score_protocol or (["densify-v1", "rect-v1"] if args.input == "scan"
                                                  else [args.protocol])
    dataset = KittiDepth(args.kitti_root, split="train", input=args.input)
    if args.input == "scan":
        sets = scan_folds(dataset, args.kitti_root)
    else:
        sets = [(name, cal, dataset, test) for name, cal, test in folds(sorted({str(g) for g in dataset.groups}))]
    checkpoints = dict(c.split("=", 1) for c in args.checkpoint)
    rows = []
    print("| fold | protocol | frames | cal. drives / pixels | coverage ± se | mean width (m) | RMSE | keep-80 % RMSE "
          "(cut ± se) | border keep-80 % (cut) | AUSE RMSE per image (m) | AUCE |\n"
          "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    curves = []
    for name, cal_drives, source, test_drives in sets:
        if name in checkpoints:
            from estimators.learned import load  # a saved fold model (torch, the [learned] extra)

            base = load(checkpoints[name])
        else:
            base = make_method(args.method)
        # Calibrate and score only drives the base never saw (a release trained on some drives).
        seen = set(getattr(base, "training_drives_", None) or ())
        cal_drives = [d for d in cal_drives if d not in seen]
        test_drives = [d for d in test_drives if d not in seen]
        if not cal_drives:
            raise SystemExit(f"{name}: the base saw every drive outside the fold; train it with calibration "
                             "drives left out too (--exclude-drives)")
        if not test_drives:
            continue
        for row in run_fold(base, spaced_per_drive(dataset, args.frames_per_drive, cal_drives),
                            spaced_per_drive(source, args.frames_per_drive, test_drives), args):
            row["fold"] = name
            rows.append(row)
            print_row(row)
            curves.append(f"| {name} | {row['protocol']} | {row['rmse_keep_90']:.2f} | {row['rmse_keep_80']:.2f} | "
                          f"{row['rmse_keep_50']:.2f} | {row['hole_rmse']:.2f} | {row['rejection_auc']:.3f} |")
    print("\nError-rejection curve (RMSE when the most confident share is kept; AUC: mean over 5 %, ..., 100 % "
          "kept ÷ RMSE):\n| fold | protocol | keep 90 % | keep 80 % | keep 50 % | all | AUC |\n|---|---|---:|---:|---:|---:|---:|")
    print("\n".join(curves))
    if args.json:
        from inpaintenv.files import write_json
        write_json(args.json, rows)
    return rows


if __name__ == "__main__":
    main()
