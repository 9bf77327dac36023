"""An example method run outside inpaintenv: fill exported inputs with OpenCV's Telea inpainting.

Usage: python docs/examples/fill_holes.py <export folder> <predictions folder>

It reads the inputs listed in the export's manifest.json (KITTI 16-bit PNGs, metres x 256,
0 = hole or no measurement) and writes one prediction per input at the same relative path
under the predictions folder. It needs OpenCV only (and NumPy, which OpenCV needs).
"""

import json
import sys
from pathlib import Path

import cv2
import numpy as np


def predict(raw: np.ndarray) -> np.ndarray:
    """One KITTI uint16 input -> a uint16 prediction with every pixel filled."""
    depth = raw.astype(np.float32) / 256  # metres
    unknown = (raw == 0).astype(np.uint8)  # the holes and the pixels without a measurement
    filled = cv2.inpaint(depth, unknown, 3, cv2.INPAINT_TELEA)
    # Back to metres x 256; at least 1 (1/256 m), since 0 would mean "left unfilled".
    return np.clip(np.rint(filled.astype(np.float64) * 256), 1, 65535).astype(np.uint16)


def main(inputs: Path, predictions: Path) -> None:
    manifest = json.loads((inputs / "manifest.json").read_text())
    for item in manifest["items"]:
        raw = cv2.imread(str(inputs / item["input"]), cv2.IMREAD_UNCHANGED)
        target = predictions / item["input"]
        target.parent.mkdir(parents=True, exist_ok=True)
        if not cv2.imwrite(str(target), predict(raw)):
            sys.exit(f"could not write {target}")


if __name__ == "__main__":
    main(Path(sys.argv[1]), Path(sys.argv[2]))
