"""The learned inpainters (PyTorch), beside :mod:`estimators.classical`.

==================  ====================================================================
module              what it holds
==================  ====================================================================
``neural``          ``UNetInpainter``, ``AutoencoderInpainter``: the study's networks
``prior``           ``PriorUNetInpainter``: networks over classical candidate fills
                    (releases ``kitti-rect-v1``..``v3``, ``kitti-mixed-v1``)
``blend``           ``BlendInpainter``: the per-pixel blend trained on pooled pixels
                    (release ``kitti-rect-v4``)
``context_blend``   ``ContextBlendInpainter``: the blend plus a low-resolution scene context
                    (releases ``kitti-context-v1``..``v3``)
``ensemble``        ``MeanEnsembleInpainter``: the per-pixel mean of several learned
                    inpainters, sharing the blend family's features
``load``            ``load_checkpoint``: any saved model, its class read from the files
``presets``         the named training recipes of ``inpaintenv train``
``distributed``     multi-process training (``torchrun -m estimators.distributed``)
``nets/``           plain ``torch.nn.Module`` networks
``losses``          the study's loss
``_neural_params``  parameter checks of the step-trained networks
``_training``       their training loop, threads, determinism
``_checkpoint``     the checkpoint format: atomic writes, checksums, shipped releases
==================  ====================================================================

Layers, bottom up: ``nets``, ``losses``, ``_checkpoint`` -> ``_training`` ->
``_neural_params`` -> ``neural`` -> ``prior`` / ``blend`` -> ``context_blend`` -> ``ensemble`` -> ``load``,
``presets`` -> ``distributed``. Classical candidate fills come from
:mod:`estimators.priors` (no torch). No module here imports this package face or
``estimators``' face.

The public import paths are ``estimators`` (every class, lazily) and the thin
re-exports ``estimators.neural``, ``estimators.prior``, ``estimators.blend``,
``estimators.context_blend``, ``estimators.ensemble``, ``estimators.presets`` and ``estimators.distributed`` that the docs and saved run
folders name; this face imports nothing, so importing one family does not load the others.
"""
