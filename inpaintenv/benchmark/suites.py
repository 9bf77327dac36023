"""Named suites of methods for ``inpaintenv benchmark``.

A suite is a list of names from :mod:`inpaintenv.methods.registry`; names whose module cannot
be imported (e.g. no torch for the neural ones) or whose weights are not shipped are
reported and skipped, never silently dropped.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

from ..exceptions import UnknownNameError
from .tasks import Task
from ..methods.learned import LEARNED_INSTALL, learned_missing
from ..methods.registry import (
    available_methods, get_spec, interval_base, is_learned, make_method, unfilled_policy,
)

__all__ = ["KINDS", "SCAN_METHODS", "SUITES", "SUITE_TASKS", "suite_methods", "suite_tasks", "LazyMethod",
           "method_kind", "registry_kind"]

#: What a method is, as the headline labels it: a classical fill, a learned model of this
#: package (a shipped release or a checkpoint), or anything else the user submits (their
#: own callable or estimator, a folder of predictions).
KINDS = ("classical", "learned", "submitted")

_PACKAGES = {"estimators.classical": "classical", "estimators.learned": "learned"}
#: Where the interval wrappers live: a built one is of its base's kind.
_WRAPPERS = "estimators.intervals"

#: The study's three baselines as it ran them (holes only, unmeasured pixels as 0 m).
STUDY_CLASSICAL = ["telea-hole", "ns-hole", "bilateral-hole"]
#: Every classical method done right (every unmeasured pixel unknown).
CLASSICAL = [
    "harmonic", "harmonic-inverse", "ipbasic", "ipbasic-scan", "scanline", "scanline-inverse", "scanline-2d",
    "nearest", "telea", "ns", "bilateral", "constant",
]
#: The learned models shipped with the package (per-pixel blends of classical fills; need torch).
PRETRAINED = ["pretrained", "blend-pretrained-mixed"]

SUITES: dict[str, list[str]] = {
    "default": PRETRAINED + CLASSICAL + STUDY_CLASSICAL,
    "classical": CLASSICAL + STUDY_CLASSICAL,
    "study": STUDY_CLASSICAL,
    "fast": PRETRAINED + ["harmonic", "harmonic-inverse", "ipbasic", "scanline", "scanline-2d", "constant"],
}


#: The methods a suite scores on single LiDAR scans (those of its members that are here): the
#: default, the strongest classical densifier of a scan (``ipbasic-scan``), and the classical
#: fills a scan is usually given to. The rest (the study's hole-only baselines, the slow
#: OpenCV fills, the map-trained blend) are scored on maps only, which keeps the run short.
SCAN_METHODS = ("pretrained", "ipbasic-scan", "ipbasic", "harmonic", "nearest", "scanline")
#: The tasks (:mod:`.tasks`) of the default run: rect-v1 on maps, and densify-v1 and rect-v1 on
#: scans with :data:`SCAN_METHODS`.
SCAN_TASKS = (Task("scan", "densify-v1", SCAN_METHODS), Task("scan", "rect-v1", SCAN_METHODS))
MAP_TASKS = (Task("map", "rect-v1"),)
#: What each suite scores when no ``--protocol`` or ``--input`` is given.
SUITE_TASKS: dict[str, tuple[Task, ...]] = {
    "default": MAP_TASKS + SCAN_TASKS, "classical": MAP_TASKS + SCAN_TASKS, "study": MAP_TASKS, "fast": MAP_TASKS,
}


def suite_tasks(suite: str | None, members: Sequence[str]) -> list[Task]:
    """The tasks of ``suite`` (rect-v1 on maps for none), each scan task limited to the ``members`` it lists."""
    tasks = []
    for task in SUITE_TASKS.get(suite or "", MAP_TASKS):
        if task.methods is not None:
            task = Task(task.input_kind, task.protocol, tuple(m for m in task.methods if m in members))
            if not task.methods:
                continue
        tasks.append(task)
    return tasks


class LazyMethod:
    """A method built only when first needed (e.g. a neural model loading weights).

    ``optional=True`` marks a suite member that may be unavailable on this machine
    (no torch, no shipped weights): the runner then skips it with a message instead of
    failing the whole run.

    ``identity`` says what the method is without building it (e.g.
    ``"checkpoint:<sha256 of its files>"``, see :mod:`inpaintenv.files.identity`);
    when None, the runner builds the method to learn its identity if a resume needs it.

    ``unfilled`` is how the runner scores the method's 0 m pixels where ground truth
    exists unless the run sets one policy for all (:func:`~inpaintenv.methods.registry.unfilled_policy`).

    ``kind`` (one of :data:`KINDS`, or None: decided by :func:`method_kind`) is what the
    headline calls the method.
    """

    lazy = True

    def __init__(
        self, factory: Callable[[], Any], optional: bool = False, identity: str | None = None,
        unfilled: str = "error", kind: str | None = None,
    ):
        self.factory = factory
        self.optional = optional
        self.identity = identity
        self.unfilled = unfilled
        self.kind = kind

    def __call__(self) -> Any:
        return self.factory()


def suite_methods(
    suite: str, *, overrides: dict[str, Any] | None = None, warn: Callable[[str], None] = print
) -> dict[str, Any]:
    """Build the methods of ``suite`` by name (lazily).

    Parameters
    ----------
    suite : str
        A key of :data:`SUITES`.
    overrides : dict, optional
        Constructor keywords applied to every method that accepts them (e.g. ``n_jobs``).
    warn : callable
        Receives one line per method skipped because it is not available here, and one
        line for all the learned ones left out when the ``[learned]`` extra is missing.
    """
    if suite not in SUITES:
        raise UnknownNameError(f"unknown suite {suite!r}; available: {', '.join(SUITES)}")
    known = set(available_methods())
    names = SUITES[suite]
    learned = [name for name in names if name in known and is_learned(name)]
    if learned and (missing := learned_missing()):
        # The classical rest still gives a result: a user scoring their own method needs no torch.
        warn(f"left out the learned methods {', '.join(learned)}: {' and '.join(missing)} not installed; "
             f"to score them, {LEARNED_INSTALL}")
        names = [name for name in names if name not in learned]
    out: dict[str, Any] = {}
    for name in names:
        if name not in known:
            warn(f"skipping {name!r}: not registered here (its package or weights are missing)")
            continue
        out[name] = LazyMethod(
            lambda name=name: build_method(name, overrides or {}), optional=True, unfilled=unfilled_policy(name),
            kind=registry_kind(name),
        )
    return out


def _package_kind(module: str) -> str | None:
    return next((kind for package, kind in _PACKAGES.items() if module == package or module.startswith(package + ".")),
                None)


def registry_kind(name: str) -> str:
    """The kind of registered method ``name``: where its class lives (``estimators.classical``:
    classical, ``estimators.learned``: learned); a shipped interval calibration
    (``pretrained-intervals``, ``scanline-intervals``) is of its base's kind; a method
    registered from elsewhere is submitted."""
    if (base := interval_base(name)) is not None:
        return registry_kind(base)
    return _package_kind(get_spec(name).module) or "submitted"


def method_kind(name: str, method: Any) -> str:
    """What ``method``, shown as ``name``, is: one of :data:`KINDS`.

    In order: its own ``kind`` attribute (a :class:`LazyMethod`, or any method that says
    so); a built object's class from this package's ``estimators.classical`` or
    ``estimators.learned`` (an ``estimators.intervals`` wrapper: its base's); a lazy method of
    a saved checkpoint (its identity) is learned, one named like a registered method has that method's kind; anything else -- a user's
    callable or estimator, a folder of predictions -- is submitted.
    """
    kind = getattr(method, "kind", None)
    if kind in KINDS:
        return kind
    if not getattr(method, "lazy", False):
        module = getattr(type(method), "__module__", "") or ""
        if (module == _WRAPPERS or module.startswith(_WRAPPERS + ".")) and hasattr(method, "estimator"):
            return method_kind(name, method.estimator)
        return _package_kind(module) or "submitted"
    if str(getattr(method, "identity", None) or "").startswith("checkpoint:"):
        return "learned"
    return registry_kind(name) if name in available_methods() else "submitted"


def build_method(name: str, overrides: dict[str, Any]) -> Any:
    """``make_method(name)`` with only the overrides its estimator accepts."""
    method = make_method(name)
    params = method.get_params() if hasattr(method, "get_params") else {}
    usable = {k: v for k, v in overrides.items() if k in params}
    if usable:
        method.set_params(**usable)
    return method
