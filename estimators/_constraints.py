"""Parameter constraints of the estimators, declared once per class (classical, interval and learned).

Each class lists its parameters in ``_parameter_constraints`` (as scikit-learn's estimators
do): for each name, the constraints one of which the value must meet (``None`` in the list
allows None). :class:`ConstrainedParams` checks the table at ``fit`` and wherever the
parameters are read (``predict``, ``load``), then the rules that tie several parameters
together (:meth:`ConstrainedParams._check_param_relations`). A violation is one error naming
the parameter, what it accepts and the value given.

A local equivalent of ``sklearn.utils._param_validation`` (private there): the errors are
inpaintenv's (``except ValueError`` / ``except TypeError`` still work), a size above the
limits of :mod:`estimators.learned._limits` (or a constraint's own ``limit``) reads as those limits do, and NumPy scalars
and ``numpy.bool_`` are accepted where their Python counterparts are.
"""

from __future__ import annotations

import math
import operator
import weakref
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from inpaintenv.conventions import is_int
from inpaintenv.exceptions import InvalidInputError, InvalidTypeError


__all__ = [
    "Bool", "Check", "ConstrainedParams", "Constraint", "InstanceOf", "Integer", "Options", "Pair", "Real",
    "Sequence", "check_at_most", "validate_params",
]


def check_at_most(name: str, value: Any, limit: int) -> None:
    """Raise one ``ValueError`` if the (already type-checked) integer ``value`` exceeds ``limit``."""
    if value > limit:
        raise InvalidInputError(f"{name}={value!r} is more than the {limit} allowed "
                                "(estimators.learned._limits); lower it")


class Constraint:
    """One kind of accepted value; ``str()`` says which, after "must be"."""

    #: The error raised when no constraint of a parameter is met.
    error: type[Exception] = InvalidInputError

    def is_satisfied_by(self, value: Any) -> bool:
        raise NotImplementedError

    def check_limits(self, name: str, value: Any) -> None:
        """Raise the size-limit error for a value this constraint otherwise accepts."""


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))


class Integer(Constraint):
    """An integer (not a bool) ``>= low`` (and ``<= high``, a hard bound such as OpenCV's);
    above ``limit`` it is the size limit's error."""

    def __init__(self, low: int, limit: int | None = None, *, high: int | None = None):
        self.low, self.limit, self.high = low, limit, high

    def is_satisfied_by(self, value: Any) -> bool:
        return is_int(value) and self.low <= operator.index(value) and (self.high is None or value <= self.high)

    def check_limits(self, name: str, value: Any) -> None:
        if self.limit is not None:
            check_at_most(name, value, self.limit)

    def __str__(self) -> str:
        return f"an integer >= {self.low}" if self.high is None else f"an integer in [{self.low}, {self.high}]"


class Real(Constraint):
    """A finite number in an interval; ``closed`` says which ends belong to it."""

    def __init__(self, low: float | None, high: float | None = None, closed: str = "both"):
        self.low, self.high, self.closed = low, high, closed

    def is_satisfied_by(self, value: Any) -> bool:
        if not _is_number(value) or not math.isfinite(value):
            return False
        left = self.closed in ("both", "left")
        right = self.closed in ("both", "right")
        above = self.low is None or (value >= self.low if left else value > self.low)
        below = self.high is None or (value <= self.high if right else value < self.high)
        return above and below

    def __str__(self) -> str:
        if self.high is None:
            op = ">=" if self.closed in ("both", "left") else ">"
            return f"a finite number {op} {self.low:g}"
        left = "[" if self.closed in ("both", "left") else "("
        right = "]" if self.closed in ("both", "right") else ")"
        return f"a number in {left}{self.low:g}, {self.high:g}{right}"


class Bool(Constraint):
    """True or False (``numpy.bool_`` too); a wrong type is a ``TypeError``."""

    error = InvalidTypeError

    def is_satisfied_by(self, value: Any) -> bool:
        return isinstance(value, (bool, np.bool_))

    def __str__(self) -> str:
        return "True or False"


class Options(Constraint):
    """One of the listed values (``1`` is not ``True`` here; a ``numpy.str_`` is a string)."""

    def __init__(self, *values: Any):
        self.values = values

    def is_satisfied_by(self, value: Any) -> bool:
        flag = isinstance(value, (bool, np.bool_))
        return any(
            isinstance(v, bool) == flag and (isinstance(v, bool) or _same_kind(v, value)) and v == value
            for v in self.values
        )

    def __str__(self) -> str:
        return f"one of {self.values}"


def _same_kind(option: Any, value: Any) -> bool:
    """``value`` has ``option``'s type (any ``str`` subclass for a string option)."""
    return type(option) is type(value) or (isinstance(option, str) and isinstance(value, str))


class InstanceOf(Constraint):
    """An instance of ``kind``, described as ``description``."""

    def __init__(self, kind: type, description: str):
        self.kind, self.description = kind, description

    def is_satisfied_by(self, value: Any) -> bool:
        return isinstance(value, self.kind)

    def __str__(self) -> str:
        return self.description


class Sequence(Constraint):
    """A non-empty tuple (or list) of items meeting ``item``; sizes checked against limits."""

    def __init__(self, item: Constraint, length: int | None = None, max_len: int | None = None,
                 max_item: int | None = None, noun: str | None = None):
        self.item, self.length, self.max_len, self.max_item = item, length, max_len, max_item
        self.noun = noun

    def is_satisfied_by(self, value: Any) -> bool:
        if not isinstance(value, (tuple, list)) or not value:
            return False
        if self.length is not None and len(value) != self.length:
            return False
        return all(self.item.is_satisfied_by(v) for v in value)

    def check_limits(self, name: str, value: Any) -> None:
        if self.max_len is not None:
            check_at_most(f"len({name})", len(value), self.max_len)
        if self.max_item is not None:
            check_at_most(f"max({name})", max(value), self.max_item)

    def __str__(self) -> str:
        item = str(self.item).replace("an integer", "integers").replace("a number", "numbers")
        item = item.replace("a finite number", "finite numbers")
        return self.noun or f"a non-empty tuple of {item}"


def Pair(item: Constraint, noun: str) -> Sequence:  # noqa: N802 (reads as a constraint class)
    """Exactly two items meeting ``item`` (e.g. a crop ``(h, w)``)."""
    return Sequence(item, length=2, noun=noun)


class Check(Constraint):
    """A value checked by ``check(value)``, which raises its own clear error (a protocol name,
    candidate fills, a seed): the table still lists the parameter, the check stays where it lives."""

    def __init__(self, check: Callable[[Any], Any]):
        self.check = check

    def is_satisfied_by(self, value: Any) -> bool:
        self.check(value)
        return True

    def __str__(self) -> str:
        return getattr(self.check, "__name__", "valid")


def validate_params(owner: Any, constraints: Mapping[str, list[Constraint | None]],
                    value_of: Callable[[str], Any] | None = None) -> None:
    """Check ``owner``'s attributes named in ``constraints`` (read by ``value_of(name)``, default ``getattr``).

    Raises
    ------
    InvalidInputError, InvalidTypeError
        ``"<name> must be <accepted> [or None], got <value>"`` for the first parameter that
        meets none of its constraints (a ``TypeError`` when only a bool was accepted), or
        the size-limit error of a value above :mod:`estimators.learned._limits`.
    """
    for name, options in constraints.items():
        value = getattr(owner, name) if value_of is None else value_of(name)
        allowed = [c for c in options if c is not None]
        if value is None and None in options:
            continue
        met = next((c for c in allowed if c.is_satisfied_by(value)), None)
        if met is not None:
            met.check_limits(name, value)
            continue
        accepted = " or ".join([str(c) for c in allowed] + (["None"] if None in options else []))
        error = InvalidTypeError if all(c.error is InvalidTypeError for c in allowed) else InvalidInputError
        raise error(f"{name} must be {accepted}, got {value!r}")


#: id of an estimator -> (a weak reference to it, the parameter values last checked). Kept outside
#: the estimator, so a predict leaves its ``__dict__`` as it was and a clone or a pickle starts unchecked.
_CHECKED: dict[int, tuple[weakref.ref, tuple[Any, ...]]] = {}


def _param_values(est: Any) -> tuple[Any, ...]:
    return tuple(est._param_value(name) for name in est._parameter_constraints)


def _remember_checked(est: Any) -> None:
    key = id(est)
    try:
        ref = weakref.ref(est, lambda _, key=key: _CHECKED.pop(key, None))
    except TypeError:  # pragma: no cover - an object without weak references is checked every time
        return
    _CHECKED[key] = (ref, _param_values(est))


def _checked_already(est: Any) -> bool:
    """Whether ``est``'s current parameter values are the very objects it last checked."""
    entry = _CHECKED.get(id(est))
    if entry is None or entry[0]() is not est:
        return False
    values = _param_values(est)
    return len(values) == len(entry[1]) and all(a is b for a, b in zip(values, entry[1]))


class ConstrainedParams:
    """Checks a class's ``_parameter_constraints`` (then its cross-parameter rules) in one place."""

    #: Parameter name -> constraints, one of which its value must meet (None allows None).
    _parameter_constraints: dict[str, list[Constraint | None]] = {}

    def _check_params(self) -> None:
        """Raise one clear error for the first parameter outside its documented range."""
        validate_params(self, self._parameter_constraints, self._param_value)
        self._check_param_relations()
        _remember_checked(self)

    def _check_params_once(self) -> None:
        """:meth:`_check_params`, unless these very parameter values were checked last (by a fit or an
        earlier predict): scikit-learn validates once per fit, not per predict batch. A value set
        since (``set_params``, an assignment) is checked at the next call."""
        if not _checked_already(self):
            self._check_params()

    def _param_value(self, name: str) -> Any:
        """The value of parameter ``name`` as set (an attribute, unless a class stores it otherwise)."""
        return getattr(self, name)

    def _check_param_relations(self) -> None:
        """Rules that tie several (already checked) parameters together; none by default."""
