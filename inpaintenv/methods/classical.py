"""The classical methods by name: the one table the registry registers and the interval wrapper reads.

A data module (no imports of ``estimators``), so that a module of ``estimators`` that builds
a classical fill by name needs no registry.
"""

from __future__ import annotations

from typing import Any

__all__ = ["CLASSICAL_METHODS", "CLASSICAL_MODULE"]

#: The module the classes below live in.
CLASSICAL_MODULE = "estimators.classical"

#: The classical baselines: both the study's way (fill="hole": only the occlusion is
#: filled, LiDAR gaps stay 0 and can flow into the hole as 0 m, scored as 0 m as the study
#: did) and the right way (fill="invalid": every missing pixel).
#: Each row: name, class in CLASSICAL_MODULE, constructor keywords, description.
CLASSICAL_METHODS: tuple[tuple[str, str, dict[str, Any], str], ...] = (
    ("telea", "TeleaInpainter", {"fill": "invalid"}, "OpenCV Telea, fills every missing pixel"),
    ("telea-hole", "TeleaInpainter", {"fill": "hole"}, "OpenCV Telea as the study ran it (hole only)"),
    ("ns", "NavierStokesInpainter", {"fill": "invalid"}, "OpenCV Navier-Stokes, every missing pixel"),
    ("ns-hole", "NavierStokesInpainter", {"fill": "hole"}, "OpenCV Navier-Stokes as the study ran it"),
    ("bilateral", "IterativeBilateralInpainter", {"fill": "invalid"}, "iterative bilateral, every missing pixel"),
    ("bilateral-hole", "IterativeBilateralInpainter", {"fill": "hole"}, "iterative bilateral as the study ran it"),
    ("ipbasic", "IPBasicInpainter", {}, "IP-Basic-style morphological depth completion"),
    ("ipbasic-scan", "IPBasicInpainter", {"large_hole_kernel": None},
     "IP-Basic without the large-hole fill: the strongest single classical densifier of a scan"),
    ("harmonic-ipbasic", "MeanInpainter", {"methods": ("harmonic", "ipbasic-scan")},
     "per-pixel mean of harmonic and ipbasic-scan: the default for a single scan"),
    ("nearest", "NearestInpainter", {}, "nearest measured pixel"),
    ("harmonic", "HarmonicInpainter", {}, "harmonic (Laplace) interpolation"),
    ("harmonic-inverse", "HarmonicInpainter", {"inverse": True}, "harmonic interpolation of inverse depth (exact on planes)"),
    ("scanline", "ScanlineInpainter", {}, "row-wise linear interpolation of depth"),
    ("scanline-inverse", "ScanlineInpainter", {"inverse": True}, "row-wise linear interpolation of inverse depth"),
    ("scanline-2d", "ScanlineInpainter", {"vertical": True}, "row- and column-wise interpolation, blended by gap length"),
    ("constant", "ConstantInpainter", {}, "median of the measured pixels"),
)
