"""Figures drawn straight into an image: tiles of pixels, text, horizontal colour bars, PNG bytes.

For figures that are mostly images (the benchmark's frame panels). matplotlib lays out a set of
axes per tile and resamples every full-size tile at draw time; here the data is sampled to the
shown size first (:func:`sample_grid`), coloured there (:mod:`.style`), and placed on one canvas.
Text is set in matplotlib's own font (DejaVu Sans, shipped with matplotlib) through Pillow, colour
bars use the same colour maps and tick choice as matplotlib's, so the look matches the other figures.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from . import style

__all__ = ["Canvas", "colour_rgb", "fit_size", "png_bytes", "sample_grid", "text_width"]

#: PNG compression level of :meth:`Canvas.png`: zlib's fastest. Without PNG's row filters: a panel of
#: colour-mapped tiles holds few colours, which filtering spreads (a KITTI panel: 0.34 MB unfiltered
#: against 0.47 MB with Pillow's adaptive filters, in half the time).
PNG_COMPRESS_LEVEL = 1


@lru_cache(maxsize=16)
def _font(px: int) -> Any:
    import matplotlib
    from PIL import ImageFont

    return ImageFont.truetype(str(Path(matplotlib.get_data_path()) / "fonts" / "ttf" / "DejaVuSans.ttf"), px)


def text_width(text: str, px: int) -> int:
    """Width in pixels of the widest line of ``text`` set at ``px`` pixels."""
    return max(int(np.ceil(_font(px).getlength(line))) for line in text.split("\n"))


def fit_size(text: str, width: int, px: int, smallest: int = 8) -> int:
    """The largest font size from ``px`` down to ``smallest`` at which ``text`` fits ``width`` pixels."""
    while px > smallest and text_width(text, px) > width:
        px -= 1
    return px


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


def colour_rgb(colour: Any) -> tuple[int, int, int]:
    """A matplotlib colour (name, hex, RGB floats) as 0-255 RGB integers."""
    import matplotlib.colors as mcolors

    return tuple(int(round(255 * c)) for c in mcolors.to_rgb(colour))  # type: ignore[return-value]


class Canvas:
    """A white image of ``width`` x ``height`` pixels to place tiles, text and colour bars on."""

    def __init__(self, width: int, height: int) -> None:
        from PIL import Image, ImageDraw

        self.image = Image.new("RGB", (int(width), int(height)), (255, 255, 255))
        self._draw = ImageDraw.Draw(self.image)

    @classmethod
    def of(cls, pixels: np.ndarray) -> Canvas:
        """A canvas holding ``(H, W, 3)`` uint8 ``pixels`` (drawn on by OpenCV first: lines, markers)."""
        from PIL import Image, ImageDraw

        canvas = cls.__new__(cls)
        canvas.image = Image.fromarray(np.ascontiguousarray(pixels, dtype=np.uint8))
        canvas._draw = ImageDraw.Draw(canvas.image)
        return canvas

    def tile(self, rgb: np.ndarray, x: int, y: int) -> None:
        """Place a float RGB image in ``[0, 1]`` (:mod:`.style`'s) with its top-left corner at ``(x, y)``."""
        from PIL import Image

        self.image.paste(Image.fromarray(style.to_uint8(rgb)), (int(x), int(y)))

    def text(self, x: float, y: float, text: str, px: int, colour: Any = "black", anchor: str = "ma") -> None:
        """Set ``text`` (lines split at ``\\n``, centred) at ``(x, y)``; ``anchor`` as Pillow's (default: top centre)."""
        # A file name that is not UTF-8 reaches here as surrogate escapes, which no font can set: shown as \udcXX.
        text = text.encode("utf-8", "backslashreplace").decode("utf-8")
        if "\n" in text:
            self._draw.multiline_text((x, y), text, fill=colour_rgb(colour), font=_font(px), anchor=anchor,
                                      align="center", spacing=2)
        else:
            self._draw.text((x, y), text, fill=colour_rgb(colour), font=_font(px), anchor=anchor)

    def vertical_text(self, x: float, y: float, text: str, px: int, colour: Any = "black") -> None:
        """Set ``text`` turned a quarter left (read bottom to top), its left edge at ``x``, centred on ``y``."""
        from PIL import Image, ImageDraw

        text = text.encode("utf-8", "backslashreplace").decode("utf-8")
        strip = Image.new("RGB", (text_width(text, px) + 2, px + 4), (255, 255, 255))
        ImageDraw.Draw(strip).text((1, 1), text, fill=colour_rgb(colour), font=_font(px))
        turned = strip.rotate(90, expand=True)
        self.image.paste(turned, (int(round(x)), int(round(y - turned.height / 2))))

    def colourbar(self, x: int, y: int, width: int, cmap: str, vmax: float, label: str, px: int = 11) -> int:
        """A horizontal colour bar of ``cmap`` on ``[0, vmax]`` at ``(x, y)``, ticks below and ``label`` under them.

        Returns the height it took.
        """
        from matplotlib.ticker import MaxNLocator

        bar = 12
        ramp = style.lookup_table(cmap)[np.linspace(0, 255, max(width, 1)).round().astype(np.intp)]
        self.tile(np.broadcast_to(ramp[None], (bar, width, 3)), x, y)
        self._draw.rectangle((x, y, x + width - 1, y + bar - 1), outline=(0, 0, 0))
        ticks = MaxNLocator(nbins=max(3, min(9, width // 90)), steps=[1, 2, 2.5, 5, 10]).tick_values(0.0, vmax)
        for t in ticks[(ticks >= 0) & (ticks <= vmax * (1 + 1e-9))]:
            tx = x + (width - 1) * float(t) / vmax
            self._draw.line((tx, y + bar, tx, y + bar + 3), fill=(0, 0, 0))
            self.text(tx, y + bar + 4, f"{float(t):g}", px)
        self.text(x + width / 2, y + bar + 7 + px, label, px)
        return bar + 9 + 2 * px

    def png(self) -> bytes:
        """The canvas as PNG bytes (:func:`png_bytes`)."""
        return png_bytes(self.pixels())

    def pixels(self) -> np.ndarray:
        """The canvas as a ``(H, W, 3)`` uint8 array."""
        return np.asarray(self.image)
