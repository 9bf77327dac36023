"""Every estimator the shared suite (``test_common.py``) runs on, found, not listed.

:func:`public_classes` finds every public estimator class of ``estimators.classical``,
``estimators.learned`` and ``estimators.intervals`` (like scikit-learn's ``all_estimators``).
Each runs in its default configuration unless :data:`CONFIGS` gives small, fast ones (a
tiny network trained for one epoch, a wrapper's required estimator); the shipped default
methods by name (:data:`DEFAULT_METHODS`) run too. A new public class is checked the day it
is exported; ``test_common.py`` fails if a class has no instance or a configuration names
no class. Ids in the test report are the instances' reprs.
"""

from __future__ import annotations

import importlib
import inspect
from collections.abc import Callable
from typing import Any

SUBPACKAGES = ("estimators.classical", "estimators.learned", "estimators.intervals")


def public_classes() -> dict[str, type]:
    """Name -> class, for every public class with ``get_params`` of :data:`SUBPACKAGES`."""
    found = {}
    for package in SUBPACKAGES:
        module = importlib.import_module(package)
        for name in module.__all__:
            obj = getattr(module, name)
            if inspect.isclass(obj) and hasattr(obj, "get_params") and hasattr(obj, "predict"):
                found[name] = obj
    return found


def _harmonic() -> Any:
    from estimators.classical import HarmonicInpainter

    return HarmonicInpainter()


def _nearest() -> Any:
    from estimators.classical import NearestInpainter

    return NearestInpainter()


def _context(**extra: Any) -> dict[str, Any]:
    return dict(n_context=2, context_widths=(4, 4), width=4, layers=1, epochs=1, masks_per_frame=1, keep=(1.0,),
                pixels_per_frame=50, batch_frames=2, batch_pixels=32, num_threads=1, **extra)


_BLEND = dict(width=4, layers=1, epochs=1, masks_per_frame=1, pixels_per_frame=50, batch_pixels=64, num_threads=1)

#: Class name -> functions making its small configurations' keyword arguments (several
#: configurations give several instances); a class not named here runs as ``cls()``.
#: Tiny neural nets (one epoch, one thread) keep the suite fast. depth=1: scikit-learn's
#: checks fit on (n_samples, 2) arrays, read as 2-pixel-wide frames, and fit refuses frames
#: narrower than 2**depth.
CONFIGS: dict[str, list[Callable[[], dict[str, Any]]]] = {
    "TeleaInpainter": [dict, lambda: dict(fill="hole", radius=3)],
    "NavierStokesInpainter": [dict, lambda: dict(fill="hole")],
    "IterativeBilateralInpainter": [lambda: dict(iterations=3), lambda: dict(iterations=3, fill="hole")],
    "IPBasicInpainter": [dict, lambda: dict(fallback="nearest", blur="bilateral", extrapolate=True),
                         lambda: dict(fallback="scanline", blur="none")],
    "ScanlineInpainter": [dict, lambda: dict(inverse=True, vertical=True)],
    "MeanInpainter": [lambda: dict(methods=("harmonic", "nearest"))],
    "UNetInpainter": [lambda: dict(width=4, depth=1, batch_size=2, epochs=1, random_state=0, num_threads=1)],
    "AutoencoderInpainter": [lambda: dict(width=4, depth=1, batch_size=2, epochs=1, input_mask=True,
                                          depth_scale="frame", random_state=0, num_threads=1)],
    "PriorUNetInpainter": [lambda: dict(width=4, levels=1, batch_size=2, max_steps=2, random_state=0, num_threads=1)],
    "BlendInpainter": [lambda: dict(_BLEND)],
    "ContextBlendInpainter": [_context],
    "ScanBlendInpainter": [lambda: dict(near_distance=1.0, width=4, epochs=1, pixels_per_frame=200, batch_pixels=64,
                                        num_threads=1)],
    # One ring step: the checks' scans (every other row of their maps) have no calibration to find rings by.
    "SparseResidualInpainter": [lambda: dict(rings=(1,), width=4, epochs=1, pixels_per_frame=200, batch_pixels=64,
                                             num_threads=1)],
    "MeanEnsembleInpainter": [lambda: dict(estimators=[
        ("context", _class("ContextBlendInpainter")(**_context())), ("blend", _class("BlendInpainter")(**_BLEND))])],
    "InputRoutedInpainter": [lambda: dict(map_method=_harmonic(), scan_method=_nearest())],
    "ConformalIntervalInpainter": [lambda: dict(estimator=_harmonic(), max_fit_pixels=5_000)],
}

#: The shipped defaults by name, as a user gets them (``make_method``).
DEFAULT_METHODS = ("pretrained",)


def _class(name: str) -> type:
    return public_classes()[name]


def _instances() -> list[Any]:
    from inpaintenv.methods.registry import make_method

    out = [cls(**make()) for name, cls in sorted(public_classes().items()) for make in CONFIGS.get(name, [dict])]
    return out + [make_method(name) for name in DEFAULT_METHODS]


ESTIMATORS = _instances()
