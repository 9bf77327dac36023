"""One look for every figure: the depth and error colour maps, method colours, holes.

Used by the panels of :mod:`inpaintenv.envs.render` (``env.render()``, ``inpaintenv
show``) and by the benchmark's figures (:mod:`inpaintenv.benchmark.figures`), so a
colour means the same thing in all of them:

* depth: matplotlib's ``viridis`` reversed on ``[0, max_depth]`` (near = bright yellow, far =
  dark purple), with a colour bar in metres: perceptually uniform (equal steps in metres look
  like equal steps in colour; ``turbo``/``jet`` show false edges where their hue turns), its
  lightness falls with depth so it reads in grey scale and for colour-blind readers, and it
  shares no colour with the grey of pixels without data;
* absolute error: ``magma`` on ``[0, error_max]`` (black = exact, light = large), where
  ``error_max`` is a robust percentile of the errors shown (:func:`error_scale`), so a
  few far pixels do not leave the panel black;
* pixels without ground truth (or not scored): :data:`NO_DATA` grey, a colour neither map uses;
* holes: outlined in black on every tile and hatched where their pixels are hidden (the
  method's input) by :func:`draw_holes`;
* methods: one colour per method for a whole run (:func:`method_colours`).

Images here are float RGB arrays in ``[0, 1]`` of shape ``(H, W, 3)``;
:func:`to_uint8` converts them for OpenCV.
"""

from __future__ import annotations

import colorsys
import hashlib
import math
from collections.abc import Iterable
from functools import lru_cache

import numpy as np

__all__ = [
    "DEPTH_CMAP", "ERROR_CMAP", "ERROR_PERCENTILE", "HATCH", "HOLE_EDGE", "METHOD_PALETTE", "NO_DATA",
    "colour_indices", "depth_rgb", "draw_holes", "error_rgb", "error_scale", "hole_marks", "lookup_table",
    "method_colours", "to_uint8",
]

#: Colour map of depth (matplotlib name): perceptually uniform, near = bright yellow, far = dark purple.
DEPTH_CMAP = "viridis_r"
#: Colour map of absolute error (matplotlib name): perceptually uniform, black = no error.
ERROR_CMAP = "magma"
#: Percentile of the shown errors that tops the error scale: a robust maximum. Hole errors
#: are heavy-tailed (a few far pixels off by tens of metres), so the top 10 % saturate
#: rather than squeeze the rest into black.
ERROR_PERCENTILE = 90.0
#: Pixels without ground truth, or not scored (error tiles).
NO_DATA = (0.80, 0.80, 0.80)
#: Stripes over hidden hole pixels (alternating with NO_DATA).
HATCH = (0.45, 0.45, 0.45)
#: Outline of the holes.
HOLE_EDGE = (0.0, 0.0, 0.0)
#: Method colours in run order: matplotlib's tab10, then ten more picked to keep every
#: pair at least ~28 CIELAB units apart (the closest pair of tab10 itself) and dark
#: enough to read on white.
METHOD_PALETTE: tuple[str, ...] = (
    "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
    "#bcbd22", "#17becf", "#0804f9", "#ff08e8", "#0b4008", "#0165fc", "#ff0789", "#886806",
    "#8fb67b", "#750851", "#fe828c", "#0504aa",
)


@lru_cache(maxsize=8)
def lookup_table(cmap: str) -> np.ndarray:
    """``(256, 3)`` float RGB samples of a matplotlib colour map (imported on first use)."""
    import matplotlib

    return np.asarray(matplotlib.colormaps[cmap](np.linspace(0.0, 1.0, 256))[:, :3], dtype=np.float32)


def colour_indices(values: np.ndarray, vmax: float) -> np.ndarray:
    """Rows of :func:`lookup_table` that colour ``values`` on ``[0, vmax]`` (NaN as 0): ``(H, W)`` uint8."""
    scaled = np.clip(np.nan_to_num(values, nan=0.0) / vmax, 0.0, 1.0)
    return np.round(scaled * 255).astype(np.uint8)


def _mapped(values: np.ndarray, vmax: float, cmap: str) -> np.ndarray:
    return lookup_table(cmap)[colour_indices(values, vmax)]


def depth_rgb(depth: np.ndarray, max_depth: float) -> np.ndarray:
    """Colour ``(H, W)`` metres with :data:`DEPTH_CMAP` on ``[0, max_depth]``.

    Pixels without depth (0 or NaN) get :data:`NO_DATA`.
    """
    d = np.asarray(depth, dtype=np.float32)
    rgb = _mapped(d, max_depth, DEPTH_CMAP)
    rgb[~(np.nan_to_num(d, nan=0.0) > 0)] = NO_DATA
    return rgb


def error_rgb(error: np.ndarray, valid: np.ndarray, error_max: float) -> np.ndarray:
    """Colour ``(H, W)`` absolute error with :data:`ERROR_CMAP` on ``[0, error_max]``.

    Pixels outside ``valid`` (not scored) get :data:`NO_DATA`.
    """
    rgb = _mapped(np.abs(np.asarray(error, dtype=np.float32)), error_max, ERROR_CMAP)
    rgb[~np.asarray(valid, dtype=bool)] = NO_DATA
    return rgb


def error_scale(errors: Iterable[np.ndarray] | np.ndarray, percentile: float = ERROR_PERCENTILE) -> float:
    """Top of the error colour scale: a percentile of the finite errors, rounded up to a round number.

    One scale for every error tile of a figure (pass all of them), so tiles compare.
    Returns 1.0 (m) when there is no finite error.
    """
    arrays = [errors] if isinstance(errors, np.ndarray) else list(errors)
    values = np.concatenate([np.abs(np.asarray(e, dtype=np.float64)).reshape(-1) for e in arrays] or [np.empty(0)])
    values = values[np.isfinite(values)]
    if values.size == 0:
        return 1.0
    top = max(float(np.percentile(values, percentile)), 0.01)
    power = 10.0 ** math.floor(math.log10(top))
    steps = (1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0)
    return next(step * power for step in steps if step * power >= top * (1 - 1e-9))


def _edge(hole: np.ndarray, width: int) -> np.ndarray:
    """Pixels of ``hole`` within ``width`` pixels of its border (4-neighbour erosion)."""
    inner = hole.copy()
    for _ in range(width):
        shrunk = inner.copy()
        shrunk[1:] &= inner[:-1]
        shrunk[:-1] &= inner[1:]
        shrunk[:, 1:] &= inner[:, :-1]
        shrunk[:, :-1] &= inner[:, 1:]
        inner = shrunk
    return hole & ~inner


def hole_marks(hole: np.ndarray, *, scale: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Where :func:`draw_holes` paints: the holes' outline and their :data:`HATCH` stripes (two bool masks)."""
    hole = np.asarray(hole, dtype=bool)
    width = max(1, round(max(scale, 1.0) * hole.shape[1] / 600))
    diagonal = np.add.outer(np.arange(hole.shape[0]), np.arange(hole.shape[1]))
    return _edge(hole, width), hole & ((diagonal // (4 * width)) % 2 == 0)


def draw_holes(rgb: np.ndarray, hole: np.ndarray, *, hatch: bool = False, scale: float = 1.0) -> np.ndarray:
    """``rgb`` with the holes outlined in :data:`HOLE_EDGE`, hatched inside when ``hatch``.

    Hatch where the hole's pixels are hidden (the method's input), outline only where
    something is drawn inside it (ground truth, reconstruction, error). Line widths grow
    with the frame (1 px up to 900 px wide, 2 px at KITTI's 1216) and with ``scale``.

    Parameters
    ----------
    rgb : numpy.ndarray
        ``(H, W, 3)`` float RGB in ``[0, 1]``; not modified.
    hole : numpy.ndarray
        ``(H, W)`` bool (or 0/1) mask.
    hatch : bool
        Draw diagonal :data:`HATCH` stripes over the hole.
    scale : float
        Image pixels per displayed pixel when the image is shown shrunk (e.g. 3.2 for a
        1216-pixel frame in a 380-pixel wide plot), so lines keep their width.
    """
    hole = np.asarray(hole, dtype=bool)
    out = np.array(rgb, dtype=np.float32, copy=True)
    edge, stripes = hole_marks(hole, scale=scale)
    if hatch:
        out[hole] = NO_DATA
        out[stripes] = HATCH
    out[edge] = HOLE_EDGE
    return out


def method_colours(names: Iterable[str]) -> dict[str, tuple[float, float, float]]:
    """One colour per method for a whole run.

    The first 20 distinct names get :data:`METHOD_PALETTE` in the order given (a suite's
    order, so a run's figures agree); later ones a colour derived from the name's hash
    (stable across runs, not guaranteed distinct).
    """
    import matplotlib.colors as mcolors

    out: dict[str, tuple[float, float, float]] = {}
    for name in dict.fromkeys(names):
        k = len(out)
        if k < len(METHOD_PALETTE):
            out[name] = tuple(float(c) for c in mcolors.to_rgb(METHOD_PALETTE[k]))
        else:
            h = int.from_bytes(hashlib.sha1(name.encode()).digest()[:4], "big")
            out[name] = colorsys.hsv_to_rgb((h % 360) / 360.0, 0.75, 0.45 + 0.4 * ((h >> 9) % 100) / 100)
    return out


def to_uint8(rgb: np.ndarray) -> np.ndarray:
    """Float RGB in ``[0, 1]`` to ``uint8``."""
    return np.round(np.clip(rgb, 0.0, 1.0) * 255.0).astype(np.uint8)
