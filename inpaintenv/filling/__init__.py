"""Fill your own depth maps and LiDAR scans: files or folders in, filled files out, in one call.

:func:`fill` is ``inpaintenv fill`` in Python. Each input file (a KITTI 16-bit depth PNG,
an ``.npy`` / ``.npz`` float array of metres, or a ``.bin`` LiDAR scan with its
calibration) becomes an output at the same path relative to its input under ``out``;
the pixels to fill are NaN (arrays), a hole mask (``holes``), boxes (``boxes``) or every
pixel without a measurement (``missing``). Measured pixels come out bit-identical, filled
ones positive and finite. Outputs that exist are skipped (the run resumes), each written
atomically; a bad file is one line naming it, and the others are still written. With
``confidence`` each depth file gets its per-pixel interval beside it (``<name>_low`` and
``<name>_high``, in the same formats), from the method's ``predict_interval``.

The parts: :mod:`.options` (:class:`FillOptions`, every option checked once),
:mod:`.plan` (which files, which outputs), :mod:`.read` (an input and its pixels to fill),
:mod:`.methods` (the method, called on a batch), :mod:`.write` (the outputs) and :mod:`.run` (the loop).

>>> from inpaintenv.filling import fill
>>> report = fill(["my_depth/"], "filled/", holes="my_masks/", method="scanline")   # doctest: +SKIP
>>> report.summary()                                                              # doctest: +SKIP
'fill: 12 written, 0 skipped, 0 failed'
"""

from .methods import fill_depth
from .options import FillOptions
from .plan import FORMATS, POINT_FORMATS, FillJob, FillReport, plan
from .read import NO_HOLES
from .run import fill

__all__ = ["FORMATS", "NO_HOLES", "POINT_FORMATS", "FillJob", "FillOptions", "FillReport", "fill", "fill_depth", "plan"]
