"""The shipped learned releases by name, whatever their class, and the default one.

>>> from estimators.learned.releases import DEFAULT_RELEASE, load_release      # doctest: +SKIP
>>> est = load_release()                                                 # the default
>>> est = load_release("kitti-rect-v4")                                  # any release by name
"""

from __future__ import annotations

import json
from typing import Any

from . import _checkpoint as ckpt
from . import load  # noqa: F401  (imports every learned family: each registers its classes)

__all__ = ["DEFAULT_RELEASE", "load_release", "shipped"]

#: The release ``-m pretrained`` (aliases ``blend-pretrained``, ``unet-pretrained``) loads:
#: the default learned method of the benchmark (docs/model_card.md).
DEFAULT_RELEASE = "kitti-ensemble-v1"


def shipped() -> dict[str, str]:
    """Every complete shipped release and the class it records."""
    out = {}
    for path in sorted(ckpt.PRETRAINED_DIR.glob("*.json")):
        if path.with_suffix(".safetensors").is_file():
            out[path.stem] = str(json.loads(path.read_text()).get("class"))
    return out


def load_release(name: str = DEFAULT_RELEASE, **overrides: Any) -> Any:
    """Load a shipped release by name (default :data:`DEFAULT_RELEASE`).

    Parameters
    ----------
    name : str
        Release name (see :func:`shipped`).
    **overrides
        Prediction-time parameters (e.g. ``tta``, ``predict_threads``).

    Raises
    ------
    KeyError
        No release of that name is shipped (the message lists them).
    """
    releases = shipped()
    if not isinstance(name, str) or name not in releases:
        raise KeyError(f"no shipped release {name!r}; shipped: {sorted(releases)}")
    klass = ckpt.checkpoint_class(releases[name])
    if klass is None or not hasattr(klass, "pretrained"):
        raise KeyError(f"release {name!r} records class {releases[name]!r}, which this version cannot load")
    return klass.pretrained(name, **overrides)
