"""Every estimator the shared suite (``test_common.py``) runs on: one flat list.

Append a small, fast configuration of any new estimator here (e.g. a tiny neural
net trained for one epoch). Ids in the test report are the instances' reprs.
"""

from __future__ import annotations

from estimators import (
    ConstantInpainter,
    HarmonicInpainter,
    IPBasicInpainter,
    IterativeBilateralInpainter,
    NavierStokesInpainter,
    NearestInpainter,
    ScanlineInpainter,
    TeleaInpainter,
)

ESTIMATORS = [
    TeleaInpainter(),
    TeleaInpainter(fill="hole", radius=3),
    NavierStokesInpainter(),
    NavierStokesInpainter(fill="hole"),
    IterativeBilateralInpainter(iterations=3),
    IterativeBilateralInpainter(iterations=3, fill="hole"),
    IPBasicInpainter(),
    IPBasicInpainter(fallback="nearest", blur="bilateral", extrapolate=True),
    IPBasicInpainter(fallback="scanline", blur="none"),
    NearestInpainter(),
    HarmonicInpainter(),
    ScanlineInpainter(),
    ScanlineInpainter(inverse=True, vertical=True),
    ConstantInpainter(),
]
