"""The named training recipes of ``inpaintenv train``.

A thin re-export of :mod:`estimators.learned.presets`, kept as the import path the docs
show (and that benchmark run folders and pickles record); the code lives in
``estimators/learned/``.
"""

from .learned import presets as _module
from .learned.presets import (
    PRESETS,
    STAGED_PRESETS,
    available_presets,
    check_preset,
    describe_preset,
    make_preset,
    preset_checkpoints,
    preset_runs_joblib,
    train_preset,
)

__all__ = [
    "PRESETS",
    "STAGED_PRESETS",
    "available_presets",
    "check_preset",
    "describe_preset",
    "make_preset",
    "preset_checkpoints",
    "preset_runs_joblib",
    "train_preset",
]

# The module's other names too, private ones included, as before the move to learned/
# (scripts written then import them from here).
globals().update({k: v for k, v in vars(_module).items() if not k.startswith("__") and k not in globals()})
