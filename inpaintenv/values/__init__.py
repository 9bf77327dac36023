"""What a value may be, checked where it enters: one module per kind of value.

The file layer (:mod:`inpaintenv.files`) checks that a file is safe to read; this package
checks that what it holds is possible. Each module owns one kind of value and is called
by every reader of that kind, so a new reader cannot forget the check:

* :mod:`~inpaintenv.values.points`: a LiDAR scan point (finite, and once projected a depth a
  16-bit PNG can hold; a scan some point of which lands in the image);
* :mod:`~inpaintenv.values.calibration`: a projection (finite, invertible, right-handed) and the
  rig a scan's folders name for it;
* :mod:`~inpaintenv.values.depth`: a depth map (each value by
  :func:`inpaintenv.conventions.check_depth`; a frame in metres, not all under a metre);
* :mod:`~inpaintenv.values.rows`: a per-frame result row (finite, non-negative errors, counts >= 0, metrics
  in their definitions' bounds, NaN only where nothing was scored, one per key, planned by its run).

A training state (the ``training.json`` and Adam's tensors a fit resumes) is a torch value:
its check is ``estimators/learned/_training_state.py`` (checksummed with the weights, and
consistent with its checkpoint folder and with the estimator resuming it), read by the one
reader of run checkpoints, ``estimators.learned._checkpoint.read_checkpoint``.

Import a check from its module (``from inpaintenv.values.points import ...``); this
package imports nothing else, so every layer may use it.
"""
