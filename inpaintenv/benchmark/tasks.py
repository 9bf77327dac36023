"""What a benchmark run scores: tasks, each an input kind and an occlusion protocol.

A task is ``(input kind, protocol)`` (:class:`Task`): ``rect-v1`` on the ground-truth map
(the input is the map with the hole cut, as always), ``rect-v1`` on single LiDAR scans
(the scan with the hole cut; :mod:`inpaintenv.data.inputs`), or ``densify-v1`` on scans
(fill every pixel the scan did not measure). In text a task is the protocol's name,
prefixed by ``scan:`` for a scan task (``"scan:densify-v1"``; ``"map:rect-v1"`` is
``"rect-v1"``).

A task may name the methods it scores (``Task.methods``): a suite scores its map methods
on maps and only the methods meant for scans on scans (see
:data:`~inpaintenv.benchmark.suites.SUITE_TASKS`); ``None`` is every method of the run.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from ..data.base import DepthDataset
from ..data.inputs import INPUT_KINDS, INPUTS, check_input_kind, input_kind
from ..exceptions import InvalidInputError, InvalidTypeError
from ..masks import get_protocol

__all__ = ["Task", "check_tasks", "parse_task", "task_datasets"]


@dataclass(frozen=True)
class Task:
    """One thing a run scores: every method of ``methods`` (None: all) under ``protocol`` on ``input_kind``."""

    input_kind: str
    protocol: str
    methods: tuple[str, ...] | None = None

    @property
    def key(self) -> tuple[str, str]:
        """``(input_kind, protocol)``: what tells two tasks apart."""
        return self.input_kind, self.protocol

    @property
    def label(self) -> str:
        """The task in text: ``"rect-v1"`` on maps, ``"scan:rect-v1"`` on scans."""
        return input_kind(self.input_kind).label(self.protocol)

    def scores(self, name: str) -> bool:
        """Whether the method ``name`` is scored in this task."""
        return self.methods is None or name in self.methods


def parse_task(value: Any, input_kind: str = "map") -> Task:
    """A :class:`Task` from a task, ``"scan:<protocol>"``, ``"map:<protocol>"``, or a protocol name
    (then of ``input_kind``); the protocol's name is checked and normalised.

    Raises
    ------
    InvalidInputError
        On an unknown input kind or protocol, or ``densify-v1`` on maps (a map input has
        nothing unmeasured to fill).
    """
    if isinstance(value, Task):
        kind, protocol, methods = value.input_kind, value.protocol, value.methods
    elif isinstance(value, str):
        kind, _, protocol = value.rpartition(":") if value.split(":", 1)[0] in INPUT_KINDS else ("", "", value)
        kind, methods = kind or input_kind, None
    else:
        raise InvalidTypeError(f"a task must be a protocol name, 'scan:<protocol>' or a Task, got {value!r}")
    check_input_kind(kind, "a task's input kind")
    proto = get_protocol(protocol)
    if INPUTS[kind].is_map and proto.task == "unmeasured":
        raise InvalidInputError(f"{proto.name} fills what a single scan did not measure: a map input has nothing "
                                f"to fill; score it on scans (--input scan, or the task 'scan:{proto.name}')")
    return Task(kind, proto.name, None if methods is None else tuple(methods))


def check_tasks(values: Any, input_kind: str = "map") -> list[Task]:
    """The run's tasks, checked: one name or task, or a sequence of them, distinct, at least one.

    Raises
    ------
    InvalidInputError, InvalidTypeError
        On no task, a task given twice, or a bad one (:func:`parse_task`).
    """
    if isinstance(values, (str, Task)):
        values = [values]
    if not isinstance(values, Sequence):
        raise InvalidTypeError(f"protocols must be a protocol name or a list of them, got {type(values).__name__}")
    tasks = [parse_task(v, input_kind) for v in values]
    if not tasks:
        raise InvalidInputError("protocols is empty; give at least one occlusion protocol")
    labels = [t.label for t in tasks]
    if len(set(labels)) != len(labels):
        raise InvalidInputError(f"protocols must be distinct, got {labels}")
    return tasks


def task_datasets(source: Any, tasks: Sequence[Task]) -> dict[str, DepthDataset]:
    """The dataset of each input kind the tasks need, from one dataset or a mapping ``{kind: dataset}``.

    Raises
    ------
    InvalidInputError
        If a task's input kind has no dataset of that kind (a scan task needs a source
        opened with ``input="scan"``), or a mapping's dataset is of another kind.
    """
    from ..evaluate import resolve_source

    given = source if isinstance(source, Mapping) else {None: source}
    datasets = {}
    for key, value in given.items():
        ds = resolve_source(value)
        if key is not None and check_input_kind(key, "a source's input kind") != ds.input_kind:
            raise InvalidInputError(f"the source given for {key!r} has input kind {ds.input_kind!r}")
        datasets[ds.input_kind] = ds
    for task in tasks:
        if task.input_kind not in datasets:
            raise InvalidInputError(
                f"task {task.label} needs a source of input kind {task.input_kind!r}; the source has "
                f"{', '.join(map(repr, datasets))} (pass source={{'map': ..., 'scan': ...}}, or open it with "
                f"input={task.input_kind!r})")
    needed = {t.input_kind for t in tasks}
    return {k: ds for k, ds in datasets.items() if k in needed}
