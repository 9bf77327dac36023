"""Named suites of methods for ``inpaintenv benchmark``.

A suite is a list of names from :mod:`inpaintenv.registry`; names whose module cannot
be imported (e.g. no torch for the neural ones) or whose weights are not shipped are
reported and skipped, never silently dropped.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from ..registry import available_methods, make_method, unfilled_policy

__all__ = ["SUITES", "suite_methods", "LazyMethod"]

#: The study's three baselines as it ran them (holes only, unmeasured pixels as 0 m).
STUDY_CLASSICAL = ["telea-hole", "ns-hole", "bilateral-hole"]
#: Every classical method done right (every unmeasured pixel unknown).
CLASSICAL = [
    "harmonic", "harmonic-inverse", "ipbasic", "scanline", "scanline-inverse", "scanline-2d", "nearest",
    "telea", "ns", "bilateral", "constant",
]
#: The learned models shipped with the package (per-pixel blends of classical fills; need torch).
PRETRAINED = ["pretrained", "blend-pretrained-mixed"]

SUITES: dict[str, list[str]] = {
    "default": PRETRAINED + CLASSICAL + STUDY_CLASSICAL,
    "classical": CLASSICAL + STUDY_CLASSICAL,
    "study": STUDY_CLASSICAL,
    "fast": PRETRAINED + ["harmonic", "harmonic-inverse", "ipbasic", "scanline", "scanline-2d", "constant"],
}


class LazyMethod:
    """A method built only when first needed (e.g. a neural model loading weights).

    ``optional=True`` marks a suite member that may be unavailable on this machine
    (no torch, no shipped weights): the runner then skips it with a message instead of
    failing the whole run.

    ``identity`` says what the method is without building it (e.g.
    ``"checkpoint:<sha256 of its files>"``, see :mod:`inpaintenv.benchmark.identity`);
    when None, the runner builds the method to learn its identity if a resume needs it.

    ``unfilled`` is how the runner scores the method's 0 m pixels where ground truth
    exists unless the run sets one policy for all (:func:`~inpaintenv.registry.unfilled_policy`).
    """

    lazy = True

    def __init__(
        self, factory: Callable[[], Any], optional: bool = False, identity: str | None = None,
        unfilled: str = "error",
    ):
        self.factory = factory
        self.optional = optional
        self.identity = identity
        self.unfilled = unfilled

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
        Receives one line per method skipped because it is not available here.
    """
    if suite not in SUITES:
        raise KeyError(f"unknown suite {suite!r}; available: {', '.join(SUITES)}")
    known = set(available_methods())
    out: dict[str, Any] = {}
    for name in SUITES[suite]:
        if name not in known:
            warn(f"skipping {name!r}: not registered here (its package or weights are missing)")
            continue
        out[name] = LazyMethod(
            lambda name=name: build_method(name, overrides or {}), optional=True, unfilled=unfilled_policy(name)
        )
    return out


def build_method(name: str, overrides: dict[str, Any]) -> Any:
    """``make_method(name)`` with only the overrides its estimator accepts."""
    method = make_method(name)
    params = method.get_params() if hasattr(method, "get_params") else {}
    usable = {k: v for k, v in overrides.items() if k in params}
    if usable:
        method.set_params(**usable)
    return method
