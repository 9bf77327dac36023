"""Every estimator's parameter table: exactly its ``get_params()`` names, and a wrong type is
one error naming the parameter.

The classes are every public class of ``estimators.classical``, ``estimators.learned`` and
``estimators.intervals`` with ``get_params`` (found, not listed by hand, so none is left out);
a class whose table is not there yet is marked below, each with its reason. Nothing is fitted.
"""

from __future__ import annotations

import importlib
import inspect
import re
from typing import Any

import pytest

from estimators.classical import HarmonicInpainter, NearestInpainter
from inpaintenv.exceptions import InpaintenvError

SUBPACKAGES = ("estimators.classical", "estimators.learned", "estimators.intervals")

#: Classes left out, and why: each must still have no table (checked below).
NO_TABLE_YET: dict[str, str] = {}
#: Parameters a class's table does not list yet (a fixed table turns its strict xfail into a
#: failure: drop the entry then).
TABLE_GAPS: dict[str, frozenset[str]] = {}
_NOT_CHECKED = "a wrong type passes _check_params (the parameter is not in the table)"
#: (class, parameter) whose wrong type is not yet one error naming it, and why.
UNCHECKED: dict[tuple[str, str], str] = {}

def _public_classes() -> dict[str, type]:
    found = {}
    for package in SUBPACKAGES:
        module = importlib.import_module(package)
        for name in module.__all__:
            obj = getattr(module, name)
            if inspect.isclass(obj) and hasattr(obj, "get_params"):
                found[name] = obj
    return found


CLASSES = _public_classes()
TESTED = {name: cls for name, cls in CLASSES.items() if name not in NO_TABLE_YET}


def _required_args(name: str) -> dict[str, Any]:
    """Valid values of the parameters a class has no default for."""
    if name == "MeanEnsembleInpainter":
        blend = CLASSES["BlendInpainter"]
        return {"estimators": [("a", blend()), ("b", blend())]}
    if name == "InputRoutedInpainter":
        return {"map_method": HarmonicInpainter(), "scan_method": NearestInpainter()}
    if name == "ConformalIntervalInpainter":
        return {"estimator": HarmonicInpainter()}
    return {}


class _WrongType:
    """A value of no type any parameter accepts."""

    def __repr__(self) -> str:
        return "<wrong type>"


def _xfail(reason: str) -> pytest.MarkDecorator:
    return pytest.mark.xfail(strict=True, reason=reason)


def test_every_class_left_out_has_no_table_yet():
    for name in NO_TABLE_YET:
        assert name in CLASSES, f"{name} is no public class any more: drop it from NO_TABLE_YET"
        assert "_parameter_constraints" not in vars(CLASSES[name]), f"{name} has a table now: test it"


@pytest.mark.parametrize("name", [
    pytest.param(n, marks=_xfail(f"not in the table yet: {sorted(TABLE_GAPS[n])}")) if n in TABLE_GAPS else n
    for n in sorted(TESTED)
])
def test_table_lists_exactly_the_parameters(name):
    cls = TESTED[name]
    est = cls(**_required_args(name))
    assert set(getattr(cls, "_parameter_constraints", {})) == set(est.get_params(deep=False))


@pytest.mark.parametrize(("name", "param"), [
    pytest.param(n, p, marks=_xfail(UNCHECKED[n, p])) if (n, p) in UNCHECKED else (n, p)
    for n in sorted(TESTED) for p in TESTED[n]._get_param_names()
])
def test_a_wrong_type_is_one_error_naming_the_parameter(name, param):
    est = TESTED[name](**_required_args(name)).set_params(**{param: _WrongType()})
    with pytest.raises(InpaintenvError) as info:
        est._check_params()
    message = str(info.value)
    assert re.search(rf"(?<![\w.]){re.escape(param)}(?!\w)", message), message
    assert "\n" not in message
