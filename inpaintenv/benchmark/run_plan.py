"""What one benchmark run scores and how: its arguments checked once, where ``run_benchmark`` takes them."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..conventions import DEFAULT_MAX_DEPTH, check_int, check_seeds
from ..data.base import DepthDataset
from ..evaluate import EvaluationPlan
from ..exceptions import InvalidInputError, InvalidTypeError
from ..masks import OcclusionProtocol
from ..metrics import Coverage
from .kept_frames import KeptFrames
from .tasks import Task, check_tasks

__all__ = ["RunPlan", "check_run"]


def check_run(
    methods: Any, protocols: Any, seeds: Any, n_frames: Any, batch_size: Any, input_kind: str = "map",
) -> tuple[list[Task], list[int]]:
    """Validate a run's arguments; return the tasks (:mod:`.tasks`) and seeds as lists.

    A single protocol name or a single int seed is accepted as a one-element list (as
    :func:`inpaintenv.evaluate.evaluate` accepts them); a plain protocol name is a task on
    ``input_kind``.
    """
    if not isinstance(methods, Mapping):
        raise InvalidTypeError(f"methods must be a mapping of name -> method, got {type(methods).__name__}")
    if not methods:
        raise InvalidInputError("methods is empty; give at least one name -> method")
    bad_names = [n for n in methods if not isinstance(n, str) or not n.strip()]
    if bad_names:
        raise InvalidInputError(f"method names must be non-empty strings, got {bad_names!r}")
    tasks = check_tasks(protocols, input_kind)
    seed_list = check_seeds(seeds, "seeds")
    if n_frames is not None:
        check_int(n_frames, "n_frames", minimum=1)
    check_int(batch_size, "batch_size", minimum=1)
    return tasks, seed_list


@dataclass(frozen=True)
class RunPlan:
    """One benchmark run: every value checked by :func:`~inpaintenv.benchmark.run_benchmark` where it
    entered; nothing here is checked again.

    Parameters
    ----------
    methods : mapping of str to method
        Display name -> method (or lazy factory), in the run's order.
    datasets : dict of str to DepthDataset
        Input kind (``"map"``, ``"scan"``) -> its ground truth.
    tasks : list of Task
        The distinct tasks (:mod:`.tasks`).
    seeds : list of int
        Distinct non-negative seeds.
    totals : dict of str to int
        Input kind -> frames in play (its dataset's first ``n_frames`` at most).
    out : pathlib.Path
        The run folder, whose lock the run holds.
    resume : bool
        Keep rows already in ``out``.
    say : callable
        Receives the run's messages.
    policies : dict of str to str
        Method name -> its checked ``unfilled`` policy.
    unfilled : str, optional
        The run-wide policy, part of the run's fingerprint; None: each method's own.
    batch_size, progress, on_bad_frame, client
        As :func:`~inpaintenv.benchmark.run_benchmark`'s, checked.
    intervals : Coverage, optional
        The checked coverage of the intervals scored, or None.
    kept : KeptFrames
        Keeps the predictions the figures draw (:mod:`.kept_frames`).
    """

    methods: Mapping[str, Any]
    datasets: dict[str, DepthDataset]
    tasks: list[Task]
    seeds: list[int]
    totals: dict[str, int]
    out: Path
    resume: bool = True
    say: Callable[[str], None] = field(default=lambda msg: None)
    policies: dict[str, str] = field(default_factory=dict)
    unfilled: str | None = None
    batch_size: int = 4
    progress: bool = True
    on_bad_frame: str = "error"
    client: Any = None
    intervals: Coverage | None = None
    kept: KeptFrames = field(default_factory=lambda: KeptFrames({}, 0))

    def evaluation(self, name: str, task: Task, protocol: OcclusionProtocol, seed: int,
                   frames: list[int]) -> EvaluationPlan:
        """The :class:`~inpaintenv.evaluate.EvaluationPlan` of method ``name`` on ``frames`` of ``task``
        (its ``protocol``) under ``seed``: the run's checked values, as they are."""
        kind = task.input_kind
        return EvaluationPlan(self.datasets[kind], protocol, [seed], frames, self.totals[kind],
                              batch_size=self.batch_size, max_depth=DEFAULT_MAX_DEPTH, on_bad_frame=self.on_bad_frame,
                              unfilled=self.policies[name], intervals=self.intervals, client=self.client)
