"""Pixels of a figure: which pixels of a frame a shrunk tile shows, and PNG bytes of an image.

A tile of a frame panel is sampled to its shown size first (:func:`sample_grid`), coloured there
(:mod:`.style`) and placed pixel for pixel by matplotlib (:mod:`.plots`), which would otherwise
resample every full-size tile at draw time; a drawn figure is encoded by :func:`png_bytes`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["png_bytes", "sample_grid"]

#: PNG compression level of :func:`png_bytes`: zlib's fastest. Without PNG's row filters: a panel of
#: colour-mapped tiles holds few colours, which filtering spreads (a KITTI panel: 0.34 MB unfiltered
#: against 0.47 MB with Pillow's adaptive filters, in half the time).
PNG_COMPRESS_LEVEL = 1


def sample_grid(shape: tuple[int, int], width: int) -> tuple[np.ndarray, np.ndarray]:
    """Row and column indices that show a ``shape`` image ``width`` pixels wide (aspect kept), nearest pixel.

    ``image[rows][:, cols]`` is what matplotlib's ``interpolation="nearest"`` would show, computed on
    the shown pixels only.
    """
    h, w = shape
    height = max(1, round(width * h / w))
    cols = np.minimum(((np.arange(width) + 0.5) * w / width).astype(np.intp), w - 1)
    rows = np.minimum(((np.arange(height) + 0.5) * h / height).astype(np.intp), h - 1)
    return rows, cols


def png_bytes(rgb: np.ndarray) -> bytes:
    """``(H, W, 3)`` (or RGBA ``(H, W, 4)``, alpha dropped) uint8 pixels as PNG bytes: zlib level
    :data:`PNG_COMPRESS_LEVEL`, no row filter."""
    import cv2

    bgr = np.ascontiguousarray(np.asarray(rgb)[..., 2::-1])
    ok, data = cv2.imencode(".png", bgr, [cv2.IMWRITE_PNG_COMPRESSION, PNG_COMPRESS_LEVEL,
                                          cv2.IMWRITE_PNG_FILTER, cv2.IMWRITE_PNG_FILTER_NONE])
    if not ok:  # OpenCV refuses only an empty image
        raise ValueError(f"cannot encode an image of shape {bgr.shape} as PNG")
    return data.tobytes()
