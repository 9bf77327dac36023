"""The methods by name, and how a method or its interval is called.

- :mod:`inpaintenv.methods.registry`: the one list of methods by name (module paths,
  imported only when a method is built); only ``benchmark/``, ``cli/`` and ``filling/``
  use it.
- :mod:`inpaintenv.methods.classical`: the table of classical fills by name, a data
  module that ``estimators`` may read without loading the registry (which names
  ``estimators``' modules).
- :mod:`inpaintenv.methods.learned`: the shipped learned releases, the defaults
  (``DEFAULT_RELEASE``, ``SCAN_DEFAULT``) and the ``[learned]`` extra's check, a torch-free
  data module that the registry and ``estimators.learned`` both read (one definition each).
- :mod:`inpaintenv.methods.calls`: call a method as :func:`inpaintenv.evaluate.evaluate`
  does (its name, output checks, ms per frame).
- :mod:`inpaintenv.methods.intervals`: ask a method for its per-pixel interval.

This ``__init__`` imports none of them, so that reading the classical table loads no
registry: each name has one public path, in the module of its job.
"""

__all__: list[str] = []
