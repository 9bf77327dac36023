"""Measure how many of the points ``inpaintenv fill --missing --points`` adds lie above the scan's field of view.

For one real scan (by default KITTI-360 2013_05_28 drive 0000, scan 100 of ``kitti-raw``), the
command is run twice, with ``--missing`` (within the field of view) and with ``--missing
--fill-all`` (every pixel). A new point is above the field of view when its elevation angle
seen from the LiDAR, ``atan2(z, hypot(x, y))``, is above the highest of the scan's own points
that project into the image. Prints one line per run: new points, the share above, the
highest ``z``. docs/fill.md quotes it.

Run from the project root::

    python docs/scripts/fill_view.py --kitti-raw-root <kitti-raw> [--method harmonic]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np

from inpaintenv.cli import main as cli
from inpaintenv.data import project_scan, read_calibration, read_scan

SCANS = "kitti360/2013_05_28_drive_0000_sync/velodyne_points/data"
CALIB = "kitti360/calibration"


def elevation(points: np.ndarray) -> np.ndarray:
    """Elevation angle (degrees) of each point seen from the LiDAR."""
    return np.degrees(np.arctan2(points[:, 2], np.hypot(points[:, 0], points[:, 1])))


def main(argv: list[str] | None = None) -> list[str]:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--kitti-raw-root", required=True, type=Path)
    parser.add_argument("--method", default="harmonic")
    args = parser.parse_args(argv)
    scans, calib_dir = args.kitti_raw_root / SCANS, args.kitti_raw_root / CALIB
    calib = read_calibration(calib_dir)
    lines = []
    for scan in sorted(scans.glob("*.bin")):
        original = read_scan(scan)
        _, index = project_scan(original, calib, return_index=True)
        top = elevation(original[np.unique(index[index >= 0])]).max()
        for extra in ([], ["--fill-all"]):
            with tempfile.TemporaryDirectory() as out:
                rc = cli(["fill", str(scan), "--calib", str(calib_dir), "--missing", *extra, "--points", "bin",
                          "-m", args.method, "--out", out, "-q"])
                assert rc == 0, f"fill failed on {scan}"
                new = read_scan(Path(out) / scan.name)[len(original):]
            above = elevation(new) > top
            lines.append(f"{scan.name} -m {args.method} --missing {' '.join(extra) or '(in view)':>10}: "
                         f"{len(new):,} new points, {above.mean():.1%} above the field of view (top "
                         f"{top:.2f} deg), z up to {new[:, 2].max():.1f} m")
            print(lines[-1])
    return lines


if __name__ == "__main__":
    main()
