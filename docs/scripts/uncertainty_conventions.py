"""The default's 90 % interval on the official frames, in both uncertainty conventions.

Maps: the official ``val`` frame(s), ``rect-v1`` seeds 0-9 (the README's map benchmark).
Scans: the slice's official frames with a scan (drive 0001 both cameras, the
``val_selection_cropped`` frames of drive 0002), ``densify-v1`` (the README's scan benchmark), as
they are and thinned to 16 and 8 laser rings (``scan-rings16-v1``, ``scan-rings8-v1``: the sparse route).
Each is filled by ``pretrained`` and its interval asked at every level of the reliability
diagram; printed per input: coverage at 90 %, AUCE, and the RMSE-based AUSE and AURG ranked
by the interval's width, pooled (pNCNN: every scored pixel, curves normalised by their start)
and per image (Poggi et al.: per frame in metres, then the mean).

Run from the project root::

    python docs/scripts/uncertainty_conventions.py --kitti-root <KITTI root>
"""

from __future__ import annotations

import argparse

import numpy as np

from inpaintenv.data import method_input, open_source
from inpaintenv.masks import get_protocol
from inpaintenv.methods.registry import make_method
from inpaintenv.metrics import CALIBRATION_LEVELS, calibration, sparsification

SCAN_DRIVES = ["2011_09_26_drive_0001_sync", "2011_09_26_drive_0002_sync"]


def score(method, gt: np.ndarray, x: np.ndarray, scored: np.ndarray) -> dict[str, float]:
    """Both conventions of one batch: ``gt`` truth, ``x`` the method's input (NaN = fill)."""
    pred = method.predict(x)
    levels = {c: method.predict_interval(x, coverage=c, prediction=pred) for c in CALIBRATION_LEVELS}
    low, high = levels[CALIBRATION_LEVELS[CALIBRATION_LEVELS.index(0.9)]]
    out = {"frames": len(gt), "rmse": float(np.sqrt(np.mean((pred - gt)[scored & (gt > 0)] ** 2)))}
    for convention in ("pooled", "per_image"):
        cal = calibration(gt, scored, levels, convention)
        sp = sparsification(pred, gt, high - low, scored, convention, "rmse")
        out[f"coverage_90 {convention}"] = float(np.nanmean(cal["coverage"][..., CALIBRATION_LEVELS.index(0.9)]))
        for name in ("auce", "ause", "aurg"):
            out[f"{name} {convention}"] = float(np.nanmean((cal if name == "auce" else sp)[name]))
    return out


def main(argv: list[str] | None = None) -> dict[str, dict[str, float]]:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--kitti-root", required=True)
    args = parser.parse_args(argv)
    method = make_method("pretrained")
    results = {}
    maps = open_source(args.kitti_root, split="val")
    gt = maps.load_batch(list(range(len(maps))))
    rect = get_protocol("rect-v1")
    holes = np.concatenate([rect.masks(gt.shape[1:], seed, list(range(len(maps)))) for seed in range(10)])
    gts = np.concatenate([gt] * 10)
    results["maps (val, rect-v1, seeds 0-9)"] = score(method, gts, np.where(holes, np.nan, gts), holes)
    for kind, label in (("scan", "scans"), ("scan-rings16-v1", "16-beam scans"), ("scan-rings8-v1", "8-beam scans")):
        scans = open_source(args.kitti_root, split="train,val_selection", camera="both", drives=SCAN_DRIVES,
                            input=kind)
        inputs = scans.load_input_batch(list(range(len(scans))))
        truth = scans.load_batch(list(range(len(scans))))
        x = method_input(inputs, np.zeros(inputs.shape, bool), "scan")
        results[f"{label} (official, densify-v1)"] = score(method, truth, x, np.isnan(x))
    for name, row in results.items():
        print(f"{name}: " + ", ".join(f"{k} {v:.3f}" if isinstance(v, float) else f"{k} {v}" for k, v in row.items()))
    return results


if __name__ == "__main__":
    main()
