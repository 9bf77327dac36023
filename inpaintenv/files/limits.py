"""Every size bound of the package, in one place.

A file is checked against these before it is decoded or allocated, so a file that only
claims to be huge (a PNG bomb, a sparse ``.npy``, a 3 GB ``.bin``) is refused in one
line instead of taking the machine's memory.
"""

from __future__ import annotations

from ..exceptions import FileTooLargeError

__all__ = [
    "MAX_FRAME_PIXELS", "MAX_JSON_BYTES", "MAX_JSON_DEPTH", "MAX_SCAN_POINTS", "MAX_TEXT_BYTES",
    "check_frame_pixels",
]

#: The most pixels a frame, mask, calibrated image or ``--size`` may have (50 M: a
#: float32 frame of that size is 200 MB; KITTI's are 0.47 M).
MAX_FRAME_PIXELS: int = 50_000_000
#: The most points a LiDAR scan may hold (an HDL-64E scan has about 120 k; 16 M points
#: of x, y, z, reflectance are 256 MB).
MAX_SCAN_POINTS: int = 16_000_000
#: The largest JSON document read (a results.json of a full-KITTI run is a few MB).
MAX_JSON_BYTES: int = 256 * 1024 * 1024
#: The deepest nesting a JSON document may have; the package writes at most about 6.
MAX_JSON_DEPTH: int = 64
#: The largest plain-text file read (calibrations, row files are read line by line).
MAX_TEXT_BYTES: int = 16 * 1024 * 1024


def check_frame_pixels(height: int, width: int, what: str) -> None:
    """Refuse a declared ``height x width`` above :data:`MAX_FRAME_PIXELS`, before any allocation.

    Raises
    ------
    FileTooLargeError
        Naming ``what``, its size and the limit.
    """
    if int(height) * int(width) > MAX_FRAME_PIXELS:
        raise FileTooLargeError(
            f"{what} declares {int(height)} x {int(width)} = {int(height) * int(width):,} pixels, more than the "
            f"{MAX_FRAME_PIXELS:,} a frame may have (inpaintenv.files.MAX_FRAME_PIXELS); not read"
        )
