"""One public path per class (issue 41 item 1): estimators.learned exports every learned name."""

from __future__ import annotations

import importlib
import importlib.util
import inspect

import pytest

import estimators

learned = pytest.importorskip("estimators.learned")

#: The modules that are gone: re-export shims and the names that collided.
_REMOVED = [f"estimators.{name}" for name in ("neural", "blend", "prior", "presets", "context_blend", "ensemble",
                                               "distributed", "priors")] + ["inpaintenv.environment"]


@pytest.mark.parametrize("module", _REMOVED)
def test_a_removed_module_path_is_gone(module):
    assert importlib.util.find_spec(module) is None


@pytest.mark.parametrize("name", sorted(learned.__all__))
def test_every_learned_name_is_exported_from_estimators_learned(name):
    value = getattr(learned, name)
    if inspect.isclass(value) and name.endswith("Inpainter"):
        # The class says where it lives (no rewritten __module__) and estimators' lazy face is the same object.
        assert value.__module__.startswith("estimators.learned.")
        assert importlib.import_module(value.__module__).__dict__[name] is value
        assert getattr(estimators, name) is value


def test_load_is_a_function_of_estimators_learned_not_a_module():
    assert inspect.isfunction(learned.load)
    assert learned.load is estimators.load
    assert "load" in learned.__all__
    assert importlib.util.find_spec("estimators.learned.load") is None
