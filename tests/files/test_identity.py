"""A benchmark method's identity: class name, parameters and weights, never its module path."""

from __future__ import annotations

import numpy as np
import pytest

from inpaintenv.benchmark import method_identity


class _Fill:
    """A minimal estimator: parameters, no network."""

    def __init__(self, value: float = 1.0) -> None:
        self.value = value

    def get_params(self, deep: bool = True) -> dict:
        return {"value": self.value}


def _moved(cls: type, module: str) -> type:
    """The same class, as if its module had been renamed."""
    return type(cls.__name__, (cls,), {"__module__": module, "__qualname__": cls.__qualname__})


def test_an_estimator_identity_does_not_name_its_module():
    here, there = _moved(_Fill, "estimators.old_place"), _moved(_Fill, "estimators.learned._new_place")
    assert method_identity(here(2.0)) == method_identity(there(2.0)) == "_Fill([('value', 2.0)])"
    assert method_identity(here(2.0)) != method_identity(here(3.0))


def test_a_plain_function_keeps_its_qualified_name():
    assert method_identity(np.nanmedian) .endswith("nanmedian")


@pytest.fixture(scope="module")
def two_ensembles():
    """Two ensembles fitted with different seeds (so their members' weights differ)."""
    learned = pytest.importorskip("estimators.learned")
    from inpaintenv.data import SyntheticStreets

    frames = SyntheticStreets(n=4, frame_shape=(32, 96), frames_per_drive=2)

    def ensemble(seed: int):
        members = [(f"u{k}", learned.UNetInpainter(width=4, depth=1, batch_size=2, max_steps=1, random_state=k,
                                                   num_threads=1)) for k in range(2)]
        return learned.MeanEnsembleInpainter(members, random_state=seed).fit(frames)

    return ensemble(0), ensemble(1)


def test_an_ensemble_identity_carries_its_members_weights(two_ensembles):
    a, b = two_ensembles
    # The seed is a parameter; make the parameters equal so only the weights differ.
    b.set_params(random_state=0)
    assert repr(sorted(a.get_params(deep=False).items())) == repr(sorted(b.get_params(deep=False).items()))
    ida, idb = method_identity(a), method_identity(b)
    assert "u0=weights:" in ida and "u1=weights:" in ida
    assert ida != idb
    assert ida == method_identity(a)
