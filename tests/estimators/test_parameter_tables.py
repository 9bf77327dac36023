"""Every estimator's parameter table: exactly its ``get_params()`` names, and a wrong type is
one error naming the parameter.

The classes are every public class of ``estimators.classical``, ``estimators.learned`` and
``estimators.intervals`` with ``get_params``, found, not listed by hand, and none excused.
Nothing is fitted.
"""

from __future__ import annotations

import re
from typing import Any

import pytest

# tests/ has no __init__.py, so pytest puts this directory on sys.path.
from instances import public_classes

from estimators.classical import HarmonicInpainter, NearestInpainter
from inpaintenv.exceptions import InpaintenvError

CLASSES = public_classes()


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


@pytest.mark.parametrize("name", sorted(CLASSES))
def test_table_lists_exactly_the_parameters(name):
    cls = CLASSES[name]
    est = cls(**_required_args(name))
    assert set(getattr(cls, "_parameter_constraints", {})) == set(est.get_params(deep=False))


@pytest.mark.parametrize(("name", "param"), [(n, p) for n in sorted(CLASSES) for p in CLASSES[n]._get_param_names()])
def test_a_wrong_type_is_one_error_naming_the_parameter(name, param):
    est = CLASSES[name](**_required_args(name)).set_params(**{param: _WrongType()})
    with pytest.raises(InpaintenvError) as info:
        est._check_params()
    message = str(info.value)
    assert re.search(rf"(?<![\w.]){re.escape(param)}(?!\w)", message), message
    assert "\n" not in message
