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
#: The implementation modules of estimators.learned, now private (their classes are exported by the package).
_PRIVATE = ("neural", "blend", "prior", "context_blend", "ensemble")


@pytest.mark.parametrize("module", _REMOVED)
def test_a_removed_module_path_is_gone(module):
    assert importlib.util.find_spec(module) is None


@pytest.mark.parametrize("name", _PRIVATE)
def test_an_implementation_module_has_only_its_private_path(name):
    assert importlib.util.find_spec(f"estimators.learned.{name}") is None
    assert importlib.util.find_spec(f"estimators.learned._{name}") is not None


@pytest.mark.parametrize("name", sorted(learned.__all__))
def test_every_learned_name_is_exported_from_estimators_learned(name):
    value = getattr(learned, name)
    if inspect.isclass(value) and name.endswith("Inpainter"):
        # The class says where it lives, a private module (no rewritten __module__): estimators.learned is its path,
        # and estimators' lazy face is the same object.
        assert value.__module__.startswith("estimators.learned._")
        assert importlib.import_module(value.__module__).__dict__[name] is value
        assert getattr(estimators, name) is value


def test_load_is_a_function_of_estimators_learned_not_a_module():
    assert inspect.isfunction(learned.load)
    assert learned.load is estimators.load
    assert "load" in learned.__all__
    assert importlib.util.find_spec("estimators.learned.load") is None
