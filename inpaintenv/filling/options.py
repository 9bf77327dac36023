"""The options of a ``fill`` run, checked once when they are made: what ``inpaintenv fill`` parses."""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from ..data.calibration import Calibration
from ..exceptions import InvalidInputError
from ..metrics import as_coverage
from .methods import check_input_choice
from .read import check_box

__all__ = ["FillOptions"]


@dataclass(frozen=True)
class FillOptions:
    """How :func:`~inpaintenv.filling.fill` fills its inputs: every option of ``inpaintenv fill``.

    Each value is checked once, when the options are made (:meth:`__post_init__`); ``fill``
    and its parts take them as they are. ``dataclasses.replace(options, batch_size=8)``
    makes changed options, checked again.

    Parameters
    ----------
    checkpoint : path-like, optional
        A saved model's folder, used instead of ``fill``'s ``method``.
    holes : path-like, optional
        A mask for every input, or a folder of masks matched by relative path (nonzero = fill).
    boxes : sequence of (x0, y0, x1, y1)
        Rectangles to fill, columns ``x0..x1-1``, rows ``y0..y1-1``; kept as a tuple of int tuples.
    missing : bool
        Fill the pixels without a measurement (densify) inside the scan's field of view: per
        column between its topmost and bottommost measured rows
        (:func:`~inpaintenv.filling.view.sensor_view`), not the sky above it.
    fill_all : bool
        With ``missing``: every pixel without a measurement, the sky included.
    calibration : path-like or Calibration, optional
        For scans (see :func:`~inpaintenv.data.calibration.read_calibration`); ``size``
        and ``camera`` are passed to it.
    size : (int, int), optional
        Image width and height, for calibrations that do not hold it.
    camera : int, optional
        The camera to project scans into.
    format : {"png", "npy", "both"}
        Depth files written per input (checked by :func:`~inpaintenv.filling.plan`).
    points : {None, "bin", "ply", "both"}
        For scans, also the original points plus the filled pixels back-projected (reflectance 0).
    overwrite : bool
        Redo inputs whose outputs exist. Otherwise an input whose outputs all exist, made
        from it by the same method and options (the ledger of ``out``), is skipped, and one
        with an output made otherwise (or not by ``fill``) fails in one line saying what differs.
    on_error : {"continue", "stop"}
        A bad input is reported and the run goes on, or stops there.
    n_jobs : int, optional
        Passed to methods that take it (the classical ones).
    batch_size : int
        Same-sized frames per ``predict`` call (>= 1).
    progress : bool
        A progress bar on a terminal, progress lines otherwise.
    log : callable, optional
        Receives each error line (default: printed to stderr).
    confidence : float, optional
        Nominal coverage in (0, 1) of a per-pixel interval written beside each depth file,
        as ``<name>_low`` and ``<name>_high`` in the same formats (low = high = the
        measurement at measured pixels, 0 where nothing was measured or filled; in a PNG
        ``high`` is capped at 65535/256 m). From the method's ``predict_interval`` (or
        ``predict(X, return_std=True)``); ``"pretrained"`` uses its shipped calibration.
        Kept as a checked :class:`~inpaintenv.metrics.Coverage`.
    intervals : path-like, optional
        With ``confidence``: a calibration saved by
        :meth:`estimators.intervals.ConformalIntervalInpainter.save` to wrap the method in.
    input : {None, "auto", "scan", "map"}
        For a method that fills each input kind its own way (``pretrained``: a single LiDAR
        scan with the scan release ``kitti-scan-v1``, a map with the map release): every input is of this
        kind, or (``"auto"``, the method's default) each input's kind is told from its measured
        density. Other methods refuse it. ``FillReport.routes`` says which method filled what.
    preview : bool
        Also write ``<name>_preview.png`` beside each input's outputs: an 8-bit colour picture of
        the input, the fill and (with ``confidence``) the interval width (:mod:`.preview`); one
        more output of the input, recorded and skipped like the others.

    Raises
    ------
    InvalidInputError
        An option out of its range, or one given without the option it needs (``fill_all``
        without ``missing``, ``intervals`` without ``confidence``).
    """

    checkpoint: str | os.PathLike | None = None
    holes: str | os.PathLike | None = None
    boxes: Sequence[tuple[int, int, int, int]] = ()
    missing: bool = False
    fill_all: bool = False
    calibration: str | os.PathLike | Calibration | None = None
    size: tuple[int, int] | None = None
    camera: int | None = None
    format: str = "png"
    points: str | None = None
    overwrite: bool = False
    on_error: str = "continue"
    n_jobs: int | None = None
    batch_size: int = 4
    progress: bool = True
    log: Callable[[str], None] | None = None
    confidence: float | None = None
    intervals: str | os.PathLike | None = None
    input: str | None = None
    preview: bool = False

    def __post_init__(self) -> None:
        """Check every option once; one error naming the first bad one."""
        if self.on_error not in ("continue", "stop"):
            raise InvalidInputError(f"on_error must be 'continue' or 'stop', got {self.on_error!r}")
        if self.batch_size < 1:
            raise InvalidInputError(f"batch_size must be >= 1, got {self.batch_size}")
        if self.confidence is not None:
            self._set("confidence", as_coverage(self.confidence, "confidence"))
        elif self.intervals is not None:
            raise InvalidInputError("--intervals is the calibration of --confidence's interval: give --confidence too")
        if self.calibration is None and (self.size or self.camera is not None):
            raise InvalidInputError("size (--size) and camera (--camera) describe the camera of calibration (--calib); "
                                    "give calibration too (--calib PATH)")
        if self.fill_all and not self.missing:
            raise InvalidInputError("fill_all (--fill-all) widens missing (--missing) to every pixel without a "
                                    "measurement; give missing too (--missing)")
        self._set("input", check_input_choice(self.input))
        self._set("boxes", tuple(check_box(b) for b in self.boxes))

    def _set(self, name: str, value: Any) -> None:
        object.__setattr__(self, name, value)  # frozen: the checked value replaces the given one, once
