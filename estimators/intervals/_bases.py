"""The fills an interval calibration names, rebuilt by name without the registry (which names this package)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from inpaintenv.methods.classical import CLASSICAL_METHODS
from inpaintenv.exceptions import InvalidInputError

__all__ = ["CLASSICAL_FILLS", "make_base"]

#: The classical fills by name (class in estimators.classical, keywords).
CLASSICAL_FILLS = {name: (cls, kwargs) for name, cls, kwargs, _ in CLASSICAL_METHODS}


def make_base(name: str) -> Any:
    """A fill by the name a calibration records: a classical method, a shipped release
    (``"pretrained"`` = the default) or a saved model's folder; without the registry, which
    names this module."""
    if name in CLASSICAL_FILLS:
        from .. import classical

        cls, kwargs = CLASSICAL_FILLS[name]
        return getattr(classical, cls)(**kwargs)
    from inpaintenv.methods.learned import DEFAULT_RELEASE, shipped

    from ..learned import load, load_release

    if name == "pretrained" or name in shipped():
        return load_release(DEFAULT_RELEASE if name == "pretrained" else name)
    if Path(name).is_dir():
        return load(name)
    raise InvalidInputError(f"cannot rebuild the base {name!r}: it is neither a classical method, a shipped release "
                            "nor a model folder; pass estimator=")
