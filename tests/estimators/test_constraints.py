"""The parameter tables of the learned estimators: one line naming parameter, range and value."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import clone

from estimators._constraints import Bool, Integer, Options, Real, Sequence, validate_params
from estimators.learned import BlendInpainter
from estimators.learned import ContextBlendInpainter
from estimators.learned import MeanEnsembleInpainter
from estimators.learned import UNetInpainter
from estimators.learned import PriorUNetInpainter
from inpaintenv.exceptions import InvalidInputError, InvalidTypeError


class _Params:
    def __init__(self, **kw):
        self.__dict__.update(kw)


TABLE = {
    "n": [Integer(1, limit=8)],
    "lr": [Real(0, closed="neither")],
    "frac": [Real(0, 1, closed="right"), None],
    "flag": [Bool()],
    "mode": [Options("a", "b")],
    "widths": [Sequence(Integer(1), max_len=3, max_item=16)],
}
GOOD = {"n": 2, "lr": 1e-3, "frac": None, "flag": True, "mode": "a", "widths": (4, 8)}


@pytest.mark.parametrize(("bad", "error", "message"), [
    ({"n": 0}, InvalidInputError, "n must be an integer >= 1, got 0"),
    ({"n": True}, InvalidInputError, "n must be an integer >= 1, got True"),
    ({"n": 2.0}, InvalidInputError, "n must be an integer >= 1, got 2.0"),
    ({"n": 9}, InvalidInputError, "n=9 is more than the 8 allowed (estimators.learned._limits); lower it"),
    ({"lr": 0}, InvalidInputError, "lr must be a finite number > 0, got 0"),
    ({"lr": float("nan")}, InvalidInputError, "lr must be a finite number > 0, got nan"),
    ({"frac": 0.0}, InvalidInputError, "frac must be a number in (0, 1] or None, got 0.0"),
    ({"flag": 1}, InvalidTypeError, "flag must be True or False, got 1"),
    ({"mode": "c"}, InvalidInputError, "mode must be one of ('a', 'b'), got 'c'"),
    ({"widths": ()}, InvalidInputError, "widths must be a non-empty tuple of integers >= 1, got ()"),
    ({"widths": "48"}, InvalidInputError, "widths must be a non-empty tuple of integers >= 1, got '48'"),
    ({"widths": (1, 2, 3, 4)}, InvalidInputError, "len(widths)=4 is more than the 3 allowed"),
    ({"widths": (32,)}, InvalidInputError, "max(widths)=32 is more than the 16 allowed"),
])
def test_one_line_names_parameter_range_and_value(bad, error, message):
    with pytest.raises(error) as info:
        validate_params(_Params(**{**GOOD, **bad}), TABLE)
    assert str(info.value).startswith(message) and "\n" not in str(info.value)


def test_an_upper_bound_and_numpy_strings():
    # OpenCV-style hard bounds read as a range; a numpy.str_ (read from an array) is a string.
    table = {"d": [Integer(1, high=31)], "mode": [Options("a", "b")]}
    validate_params(_Params(d=np.int64(31), mode=np.str_("b")), table)
    with pytest.raises(InvalidInputError, match=r"^d must be an integer in \[1, 31\], got 32$"):
        validate_params(_Params(d=32, mode="a"), table)


def test_numpy_scalars_pass_as_their_python_kind():
    validate_params(_Params(**{**GOOD, "n": np.int64(3), "lr": np.float32(0.1), "flag": np.bool_(False),
                               "frac": np.float64(1.0)}), TABLE)


@pytest.mark.parametrize("klass", [UNetInpainter, PriorUNetInpainter, BlendInpainter, ContextBlendInpainter,
                                   MeanEnsembleInpainter])
def test_every_table_entry_is_a_parameter(klass):
    # A table may leave out parameters checked where they are used (device, warm_start,
    # the ensemble's members and weights), never list a name that is not one.
    params = set(klass._get_param_names())
    assert set(klass._parameter_constraints) <= params
    assert len(klass._parameter_constraints) >= min(5, len(params) - 2)


def _count_validations(monkeypatch) -> list:
    import estimators._constraints as constraints

    calls: list = []
    original = constraints.validate_params

    def counting(owner, *args, **kwargs):
        calls.append(type(owner).__name__)
        return original(owner, *args, **kwargs)

    monkeypatch.setattr(constraints, "validate_params", counting)
    return calls


def test_parameters_are_checked_once_not_per_predict_batch(monkeypatch):
    from estimators.classical import HarmonicInpainter, IPBasicInpainter, NearestInpainter

    calls = _count_validations(monkeypatch)
    x = np.full((6, 16, 24), 5.0, np.float32)
    x[:, 4:8, 6:12] = np.nan
    for est in (NearestInpainter(), HarmonicInpainter(), IPBasicInpainter()):
        calls.clear()
        for start in range(0, 6, 2):  # three predict batches, and a fit
            est.predict(x[start:start + 2])
        est.fit(np.nan_to_num(x))
        est.predict(x)
        # Once at the first predict, once at the fit (scikit-learn validates every fit), none after.
        assert calls == [type(est).__name__] * 2, (type(est).__name__, calls)


def test_a_parameter_set_after_the_check_is_checked_at_the_next_predict(monkeypatch):
    from estimators.classical import NearestInpainter

    calls = _count_validations(monkeypatch)
    est = NearestInpainter()
    x = np.where(np.eye(8, dtype=bool)[None], np.nan, 4.0).astype(np.float32)
    est.predict(x)
    est.set_params(n_jobs=0)
    with pytest.raises(InvalidInputError, match="n_jobs"):
        est.predict(x)
    est.n_jobs = 1  # assigned, not set_params: checked again too
    est.predict(x)
    est.predict(x)
    assert len(calls) == 3
    clone(est).predict(x)  # a clone starts unchecked
    assert len(calls) == 4


@pytest.mark.parametrize("value", [3, np.int64(3), np.uint8(3), np.array(3), 3.0, np.float32(3), True, np.bool_(True),
                                   "3", None, np.array([3]), -1])
def test_one_vocabulary_of_integers(value):
    """The parameter tables' Integer and the package's check_int accept the same integers."""
    from inpaintenv.conventions import check_int

    try:
        check_int(value, "n")
        accepted = True
    except (InvalidInputError, InvalidTypeError):
        accepted = False
    assert Integer(0).is_satisfied_by(value) is accepted
