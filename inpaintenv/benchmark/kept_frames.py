"""The predictions a run's figures need, kept while the run scores them, so the figures do not run a method again.

The frame panels and the error by depth and by distance to the nearest measurement need each drawn
method's pixels on a few frames (:func:`~inpaintenv.benchmark.figures.spread_indices`); the run
predicts those very frames while it scores them. :class:`KeptFrames` keeps them, for the figures' seed
only, and per task only for the methods that can still be among the drawn ones (the best few by the
task's RMSE so far), so memory stays a few methods' frames per task. A prediction it does not hold
(a method scored by an earlier run, frames of a cluster) is predicted again by the figures.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection, Iterable, Mapping
from typing import Any

import numpy as np

__all__ = ["KeptFrames"]


class KeptFrames:
    """Predictions of the figure frames of each task, kept as the run makes them.

    Parameters
    ----------
    frames : mapping of str to collection of int
        Input kind (``"map"``, ``"scan"``) -> frame positions the figures draw.
    seed : int
        The figures' mask seed; predictions under other seeds are not kept.
    best : int
        Methods kept per task: the ``best`` lowest task RMSE so far (the figures draw the best 4).
    """

    def __init__(self, frames: Mapping[str, Collection[int]], seed: int, best: int = 4) -> None:
        self.frames = {kind: {int(i) for i in idx} for kind, idx in frames.items()}
        self.seed, self.best = int(seed), int(best)
        self._preds: dict[str, dict[str, dict[int, np.ndarray]]] = {}
        self._scores: dict[str, dict[str, float]] = {}

    def keeper(self, task: str, input_kind: str, name: str) -> Callable[[int, list[int], np.ndarray], None]:
        """The ``on_predictions`` callback that keeps ``name``'s figure frames of ``task``."""
        wanted = self.frames.get(input_kind, set())
        held = self._preds.setdefault(task, {}).setdefault(name, {})

        def keep(seed: int, indices: list[int], preds: np.ndarray) -> None:
            if seed != self.seed:
                return
            for j, i in enumerate(indices):
                if i in wanted:
                    held[int(i)] = np.array(preds[j], dtype=np.float32, copy=True)

        return keep

    def ranked(self, task: str, name: str, rows: Iterable[Mapping[str, Any]], metric: str) -> None:
        """Record ``name``'s mean ``metric`` over its ``rows`` of ``task`` and drop the kept frames of
        methods no longer among the ``best`` of the task."""
        values = [float(r[metric]) for r in rows if math.isfinite(float(r.get(metric, math.nan)))]
        scores = self._scores.setdefault(task, {})
        scores[name] = float(np.mean(values)) if values else math.inf
        keep = set(sorted(scores, key=lambda n: scores[n])[: self.best])
        for other in list(self._preds.get(task, {})):
            if other not in keep:
                del self._preds[task][other]

    def get(self, task: str, name: str, index: int) -> np.ndarray | None:
        """``name``'s prediction of frame ``index`` in ``task`` as the run made it, or None when not kept."""
        return self._preds.get(task, {}).get(name, {}).get(int(index))

    def lookup(self, task: str) -> Callable[[str, int], np.ndarray | None]:
        """:meth:`get` of one task, as the figures take it."""
        return lambda name, index: self.get(task, name, index)
