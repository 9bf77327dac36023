"""The methods known by name to the CLI and the benchmark.

This module is the only list of methods in the project (estimators never import it):
each name maps to ``(module path, class name, keyword arguments)`` and the class is
imported only when :func:`make_method` builds it, so ``import inpaintenv`` never loads
``estimators``.

The learned methods (modules under ``estimators.learned``) need the ``[learned]`` extra
(torch, safetensors); without it, naming one raises
:class:`~inpaintenv.methods.learned.MissingExtraError`, one line saying what to install. The
shipped releases and the default are read from :mod:`inpaintenv.methods.learned`.

>>> from inpaintenv.methods.registry import available_methods, make_method
>>> "telea-hole" in available_methods()
True
>>> make_method("telea-hole")                           # doctest: +SKIP
TeleaInpainter(fill='hole')
"""

from __future__ import annotations

import difflib
import importlib
import os
import sys
from dataclasses import dataclass, field
from typing import Any

from ..exceptions import InvalidInputError, InvalidTypeError, MissingDependencyError, UnknownNameError
from .classical import CLASSICAL_METHODS, CLASSICAL_MODULE
from .learned import (
    DEFAULT_RELEASE, LEARNED_DEPENDENCIES, RELEASE_DIR, SCAN_DEFAULT, learned_missing, missing_extra_error, shipped,
)

__all__ = [
    "PRETRAINED_RELEASES",
    "REMOVED_RELEASES",
    "MethodSpec",
    "available_aliases",
    "available_methods",
    "canonical_name",
    "get_spec",
    "interval_base",
    "is_learned",
    "make_method",
    "register_alias",
    "register_method",
    "register_removed",
    "resolve_class",
    "unfilled_policy",
]


@dataclass(frozen=True)
class MethodSpec:
    """How to build one named method.

    Attributes
    ----------
    module : str
        Import path of the module holding the class, e.g. ``"estimators.classical"``.
    cls : str
        Class name in that module.
    kwargs : dict
        Constructor keywords that define the variant (e.g. ``{"fill": "hole"}``).
    description : str
        One line for listings.
    unfilled : {"error", "interpolate", "zero"}
        How the benchmark and ``inpaintenv evaluate`` score this method's 0 m pixels
        where ground truth exists, unless the run says otherwise (``--unfilled``):
        ``"error"`` (refuse) for every method but the study's hole-only baselines,
        which leave unmeasured surroundings at 0 m by design and were scored so
        (``"zero"``); see :data:`inpaintenv.metrics.UNFILLED`.
    """

    module: str
    cls: str
    kwargs: dict[str, Any] = field(default_factory=dict)
    description: str = ""
    unfilled: str = "error"


_LEARNED = "estimators.learned"

_METHODS: dict[str, MethodSpec] = {}
#: alias -> canonical name (a second name that loads the same method).
_ALIASES: dict[str, str] = {}
#: former name -> the one-line error naming it gives (what to use instead).
_REMOVED: dict[str, str] = {}


def _check_name(name: str) -> None:
    if not isinstance(name, str) or not name or name != name.strip() or ":" in name:
        raise InvalidInputError(f"method names must be non-empty, without spaces at the ends or ':', got {name!r}")


def register_method(
    name: str, module: str, cls: str, kwargs: dict[str, Any] | None = None,
    description: str = "", *, overwrite: bool = False, unfilled: str = "error",
) -> MethodSpec:
    """Add a named method (e.g. a trained neural model) to the registry.

    ``unfilled`` is how runs score the method's 0 m pixels by default (see
    :class:`MethodSpec`).

    Raises
    ------
    ValueError
        If ``name`` is taken (unless ``overwrite``) or malformed, or ``unfilled`` is unknown.
    """
    _check_name(name)
    if unfilled not in ("error", "interpolate", "zero"):  # inpaintenv.metrics.UNFILLED (not imported: cheap module)
        raise InvalidInputError(f"unfilled must be 'error', 'interpolate' or 'zero', got {unfilled!r}")
    if (name in _METHODS or name in _ALIASES) and not overwrite:
        raise InvalidInputError(f"method {name!r} is already registered")
    _ALIASES.pop(name, None)
    spec = MethodSpec(module, cls, dict(kwargs or {}), description, unfilled)
    _METHODS[name] = spec
    return spec


def register_alias(alias: str, target: str) -> None:
    """Make ``alias`` another name of the registered method ``target``.

    :func:`get_spec` and :func:`make_method` accept the alias; :func:`canonical_name`
    turns it into ``target``, the name results are recorded under.

    Raises
    ------
    ValueError
        If ``alias`` is malformed or already a method or alias name.
    KeyError
        If ``target`` is not a registered method (aliases of aliases are not allowed).
    """
    _check_name(alias)
    if alias in _METHODS or alias in _ALIASES:
        raise InvalidInputError(f"method {alias!r} is already registered")
    if target not in _METHODS:
        raise UnknownNameError(f"cannot alias {alias!r} to {target!r}: no method of that name is registered")
    _ALIASES[alias] = target


def available_methods() -> list[str]:
    """Registered (canonical) method names, in registration order; aliases are not listed."""
    return list(_METHODS)


def available_aliases() -> dict[str, str]:
    """Every alias and the canonical method name it stands for."""
    return dict(_ALIASES)


def canonical_name(name: str) -> str:
    """The canonical name of ``name``: the method an alias stands for, else ``name`` itself."""
    return _ALIASES.get(name, name)


def get_spec(name: str) -> MethodSpec:
    """The :class:`MethodSpec` of ``name``.

    ``"module:attr"`` names any importable class, function or object, without registration.

    Raises
    ------
    KeyError
        For an unknown name; the message lists the known names (and close matches).
    """
    name = canonical_name(name)
    if name in _METHODS:
        return _METHODS[name]
    if name in _REMOVED:
        raise UnknownNameError(_REMOVED[name])
    if ":" in name:
        module, _, cls = name.partition(":")
        if module and cls:
            return MethodSpec(module, cls, {}, "custom method")
    close = difflib.get_close_matches(name, [*_METHODS, *_ALIASES], n=3)
    hint = f" Did you mean {', '.join(map(repr, close))}?" if close else ""
    raise UnknownNameError(
        f"unknown method {name!r}.{hint} Known methods: {', '.join(available_methods())} "
        "(or 'module:ClassName' / 'module:function')"
    )


def unfilled_policy(name: str) -> str:
    """How runs score method ``name``'s unfilled (0 m) pixels by default (:class:`MethodSpec`)."""
    return get_spec(name).unfilled


def interval_base(name: str) -> str | None:
    """The registered method that method ``name``'s shipped interval calibration wraps
    (``"kitti-ensemble-v1"`` for ``pretrained-intervals``); None for any other method."""
    spec = get_spec(name)
    base = spec.kwargs.get("name") if spec.module == _INTERVALS_MODULE else None
    return base if isinstance(base, str) and base in _METHODS else None


def is_learned(name: str) -> bool:
    """True if method ``name`` (a registered name or alias) is one of the package's learned models,
    or a shipped interval calibration of one (``pretrained-intervals``)."""
    if (base := interval_base(name)) is not None:
        return is_learned(base)
    module = get_spec(name).module
    return module == _LEARNED or module.startswith(_LEARNED + ".")


def _missing_extra(name: str, missing: list[str]) -> MissingDependencyError:
    what = "a saved learned model" if canonical_name(name) == "checkpoint" else "a learned model"
    return missing_extra_error(f"method {name!r} ({what})", missing)


def resolve_class(name: str) -> Any:
    """Import the class (or factory) of method ``name`` without building it.

    Cheap enough to check every name of a run before any work (a shipped model's
    weights are loaded only when :func:`make_method` calls the factory).

    Raises
    ------
    KeyError
        Unknown name.
    MissingExtraError
        A learned method, and the ``[learned]`` extra is not installed.
    ImportError
        The module cannot be imported or has no such class.
    """
    spec = get_spec(name)
    if not _is_custom(name) and is_learned(name) and (missing := learned_missing()):
        raise _missing_extra(name, missing)
    try:
        module = importlib.import_module(spec.module) if not _is_custom(name) else _import_custom(spec.module)
    except ImportError as exc:
        root = str(getattr(exc, "name", None) or "").partition(".")[0]
        if not _is_custom(name) and root in LEARNED_DEPENDENCIES:  # found by find_spec, yet not importable
            raise _missing_extra(name, [root]) from exc
        raise MissingDependencyError(f"method {name!r} needs module {spec.module!r}, which cannot be imported: {exc}") from exc
    try:
        return getattr(module, spec.cls)
    except AttributeError:
        raise MissingDependencyError(f"method {name!r}: module {spec.module!r} has no class {spec.cls!r}") from None


def _is_custom(name: str) -> bool:
    """True for a ``"module:attr"`` name (not registered): a user's class, function or object."""
    return canonical_name(name) not in _METHODS and ":" in name


def _import_custom(module: str) -> Any:
    """Import a user's module as ``python -m`` would find it: the current folder first on the path.

    The ``inpaintenv`` console script starts with its own folder on ``sys.path``, not the
    current one, so ``-m mymodule:fn`` beside the user's ``mymodule.py`` was not found.
    """
    cwd = os.getcwd()
    if cwd not in sys.path and "" not in sys.path:
        sys.path.insert(0, cwd)
        importlib.invalidate_caches()  # a module written since the last import must be seen
    return importlib.import_module(module)


def make_method(name: str, **overrides: Any) -> Any:
    """Build the method registered as ``name``.

    Parameters
    ----------
    name : str
        A registered name or alias (see :func:`available_methods`,
        :func:`available_aliases`) or ``"module:attr"``: a class (built with the
        overrides), or a function ``depth -> depth`` or an estimator object (returned as
        is: the method itself). The module is found as ``python -m`` finds it, the current
        folder first.
    **overrides
        Constructor keywords replacing or adding to the registered ones.

    Returns
    -------
    object
        A new, unfitted estimator (or the user's function or object).

    Raises
    ------
    KeyError
        Unknown name.
    ImportError
        The method's module cannot be imported (e.g. it is not installed).
    TypeError
        An override the class does not accept, or any override for a function or object.
    """
    spec = get_spec(name)
    cls = resolve_class(name)
    kwargs = {**spec.kwargs, **overrides}
    if _is_custom(name) and not isinstance(cls, type):
        # A user's function depth -> depth, or an estimator object: the method itself, as
        # evaluate() takes it. Calling it here would pass it no depth at all.
        if kwargs:
            raise InvalidTypeError(f"method {name!r} is a {type(cls).__name__}, not a class, so it takes no parameters; "
                            f"got {kwargs}")
        return cls
    try:
        return cls(**kwargs)
    except TypeError as exc:
        raise InvalidTypeError(f"method {name!r} ({spec.module}.{spec.cls}) rejected parameters {kwargs}: {exc}") from exc


# The classical baselines (inpaintenv.methods.classical holds their table).
for _name, _cls, _kw, _desc in CLASSICAL_METHODS:
    register_method(_name, CLASSICAL_MODULE, _cls, _kw, _desc, unfilled="zero" if _kw.get("fill") == "hole" else "error")

# The shipped learned releases (need the [learned] extra), each registered under its own
# name from its own JSON in estimators/pretrained/ (found without importing estimators).
# One factory loads any of them: estimators.learned.load_release (the release folder, the
# default and the list of releases: inpaintenv.methods.learned, the one torch-free copy).
_RELEASES_MODULE = "estimators.learned"
#: Interval calibrations (and the default, which gives each route's on asking).
_INTERVALS_MODULE = "estimators.intervals"
#: The releases that left the package (the git tag releases-0.1 holds their weights and cards).
REMOVED_RELEASES = ("kitti-rect-v1", "kitti-rect-v2", "kitti-rect-v3", "kitti-rect-v4",
                     "kitti-context-v1", "kitti-context-v2", "kitti-context-v3")


def register_removed(name: str, message: str) -> None:
    """Make ``name`` a former method name: naming it raises one :class:`UnknownNameError` with ``message``."""
    _check_name(name)
    _REMOVED[name] = message


# The default: estimators.learned.load_default, and each route's interval from the calibration
# shipped for it (asked only when an interval is: predict_interval / predict(X, return_std=True)).
register_method(
    "pretrained", _INTERVALS_MODULE, "default_intervals", {"name": DEFAULT_RELEASE, "require_calibration": False},
    f"the default: a map with holes gets the learned release {DEFAULT_RELEASE} (the per-pixel mean of a context "
    "blend and a per-pixel blend of classical fills, trained on 15 KITTI drives, CC BY-NC-SA 3.0), a single LiDAR "
    f"scan gets the scan release {SCAN_DEFAULT}; decided per frame from its measured density or by "
    "input='scan'|'map'; each route's shipped 90 % interval on asking (predict_interval, return_std)",
)
for _release, _class in shipped().items():
    register_method(_release, _RELEASES_MODULE, "load_release", {"name": _release},
                    f"the shipped release {_release} ({_class}; docs/model_cards/{_release}.md; CC BY-NC-SA 3.0)")
PRETRAINED_RELEASES: tuple[str, ...] = tuple(shipped())
if "kitti-mixed-v1" in _METHODS:
    register_method("blend-pretrained-mixed", _RELEASES_MODULE, "load_release", {"name": "kitti-mixed-v1"},
                    "kitti-mixed-v1: the per-pixel learned blend trained on all four occlusion protocols "
                    "(mixed-v1; CC BY-NC-SA 3.0)")
# Names that loaded something else than they said, and the releases that
# left the package (their weights and cards are in git under the tag releases-0.1).
register_removed("unet-pretrained", "method 'unet-pretrained' was removed: it loaded an ensemble of learned "
                 "blends, not a U-Net; use 'pretrained'")
register_removed("blend-pretrained", "method 'blend-pretrained' was removed: it loaded the input-routed default, "
                 "not a blend; use 'pretrained'")
register_removed("unet-pretrained-mixed", "method 'unet-pretrained-mixed' was removed: it loaded a learned blend, "
                 "not a U-Net; use 'blend-pretrained-mixed'")
for _release in REMOVED_RELEASES:
    register_removed(_release, f"release {_release!r} is no longer shipped (its weights are in the project's git "
                     "history, tag releases-0.1); use 'pretrained' or one of: " + ", ".join(PRETRAINED_RELEASES))

# Methods (releases, classical fills) shipped with a per-pixel interval calibration
# (estimators/pretrained/intervals/<name>.json): <name>-intervals predicts as <name> and adds
# predict_interval / predict(X, return_std=True).


def shipped_interval_calibrations() -> tuple[str, ...]:
    """The registered methods shipped with an interval calibration (found without importing estimators)."""
    folder = RELEASE_DIR / "intervals"
    return tuple(sorted(p.stem for p in folder.glob("*.json") if p.stem in _METHODS)) if folder.is_dir() else ()


for _release in shipped_interval_calibrations():
    register_method(f"{_release}-intervals", _INTERVALS_MODULE, "release_intervals", {"name": _release},
                    f"{_release} with its shipped 90 % per-pixel intervals (drive-grouped conformal; "
                    + ("docs/model_card.md" if _release in PRETRAINED_RELEASES else "docs/estimators.md")
                    + ", 'Per-pixel intervals'); predicts as " + _release)
if DEFAULT_RELEASE in shipped_interval_calibrations():
    # 'pretrained', refused when built if the map release ships no calibration: a scan's interval is
    # the scan route's own, never answered by the map release's fill and interval.
    register_method("pretrained-intervals", _INTERVALS_MODULE, "default_intervals", {"name": DEFAULT_RELEASE},
                    f"pretrained with its 90 % per-pixel intervals: a map's from {DEFAULT_RELEASE}'s shipped "
                    f"calibration, a scan's from {SCAN_DEFAULT}'s (docs/model_card.md, 'Per-pixel intervals')")
register_method(
    "intervals", _INTERVALS_MODULE, "load_intervals", {},
    "a saved interval calibration around its base: make_method('intervals', path=..., estimator=...)",
)

register_method(
    "checkpoint", "estimators.learned", "load", {},
    "a saved neural model: make_method('checkpoint', path=...)",
)
