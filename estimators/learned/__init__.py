"""The learned inpainters (PyTorch), beside :mod:`estimators.classical`: every public name here.

>>> from estimators.learned import load                                  # doctest: +SKIP
>>> from estimators.learned import MeanEnsembleInpainter, load_release
>>> est = load_release()                      # the default map release
>>> est.save("my-model"); same = load("my-model")

=====================  ===============================================================
name                   what it is
=====================  ===============================================================
``UNetInpainter``,     the study's networks
``AutoencoderInpainter``
``PriorUNetInpainter``  networks over classical candidate fills (release ``kitti-mixed-v1``)
``BlendInpainter``     the per-pixel blend trained on pooled pixels
``ContextBlendInpainter``  the blend plus a low-resolution scene context
``ScanBlendInpainter``  a single scan: a classical mean near its measurements, the blend
                       far from them (release ``kitti-scan-v1``)
``SparseResidualInpainter``  ``harmonic`` plus a learned per-pixel correction, trained on
                       scans thinned to several densities (no release yet)
``MeanEnsembleInpainter``  the per-pixel mean of several learned inpainters (release
                       ``kitti-ensemble-v1``, the default)
``load``               any saved model, its class read from its ``config.json``
``load_release``       a shipped release by name (the list and the defaults:
                       :mod:`inpaintenv.methods.learned`, torch-free)
``load_default``       the default method ``pretrained``, routed by input kind
``InputRoutedInpainter``  a map to one method, a single scan to another
``OnFirstUse``         a route's method made when the route first fills a frame
=====================  ===============================================================

Every class saves and loads through one mixin (``_persistence.PersistenceMixin``: ``save``,
``load``, ``to_config`` / ``from_config``) over two hooks on each class (``_config`` /
``_from_config``) and one file format in plain functions (``_checkpoint``: ``write_checkpoint``,
``read_model``); a load reads the folder, then the recorded class's ``_from_config`` builds the
model (``load`` lists every class it reads). A network's MRO is its class, ``_NeuralInpainter``
(parameters, prediction and config hooks; the parameter table and what the values mean in
``_neural_params``), the parameter checks, the training loop (``_training``), the persistence
mixin and ``BaseInpainter``. The training recipes are in :mod:`estimators.learned.presets`;
multi-process training is ``torchrun -m estimators.learned.distributed``.

Layers, bottom up: ``nets``, ``losses``, ``_checkpoint`` -> ``_persistence``, ``_training``
-> ``_neural_params`` -> ``_neural`` -> ``_prior`` / ``_blend`` / ``_sparse_residual`` -> ``_context_blend``,
``_scan_blend`` -> ``_ensemble`` -> ``_load`` -> ``_releases``, ``presets`` -> ``distributed``. Classical
candidate fills come from :mod:`estimators.candidates` (no torch). No module here imports this package
face or ``estimators``' face; this face imports a module only when one of its names is
first used, so importing one family does not load the others.
"""

from __future__ import annotations

import importlib
from typing import Any

from inpaintenv.methods.learned import require_learned

#: Public name -> the private module of this package that defines it.
_EXPORTS: dict[str, str] = {
    "UNetInpainter": "_neural", "AutoencoderInpainter": "_neural", "PriorUNetInpainter": "_prior",
    "BlendInpainter": "_blend", "ContextBlendInpainter": "_context_blend", "MeanEnsembleInpainter": "_ensemble",
    "InputRoutedInpainter": "_routed", "OnFirstUse": "_routed", "ScanBlendInpainter": "_scan_blend",
    "SparseResidualInpainter": "_sparse_residual",
    "load": "_load", "load_release": "_releases", "load_default": "_releases"
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        # One line naming the extra to install, not torch's ImportError from deep in a module.
        require_learned(f"estimators.learned.{name} (a learned model)")
        value = getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))
