"""One public path per name: a learned class at estimators.learned, a classical one at
estimators.classical, the interval wrapper at estimators.intervals; estimators' face keeps
only its own API (the base class, the scorers, the subpackages). inpaintenv's errors live at
inpaintenv.exceptions and the result type with its row format at inpaintenv.report.results, only."""

from __future__ import annotations

import importlib
import importlib.util
import inspect
import pkgutil

import pytest

import estimators
import estimators.classical
import estimators.intervals

learned = pytest.importorskip("estimators.learned")

#: The modules that are gone: re-export shims and the names that collided.
_REMOVED = [f"estimators.{name}" for name in ("neural", "blend", "prior", "presets", "context_blend", "ensemble",
                                               "distributed", "priors")] + ["inpaintenv.environment",
                                                                            "estimators.learned.releases"]
#: The implementation modules of estimators.learned, now private (their classes are exported by the package).
_PRIVATE = ("neural", "blend", "prior", "context_blend", "ensemble", "releases", "routed", "scan_blend")
#: What estimators' face is: its own base class and scorers, and the subpackages of the methods.
_OWN = {"BaseInpainter", "all_rmse_scorer", "hole_mae_scorer", "hole_psnr_scorer", "hole_rmse_scorer",
        "make_inpaint_scorer", "classical", "intervals", "learned"}


@pytest.mark.parametrize("module", _REMOVED)
def test_a_removed_module_path_is_gone(module):
    assert importlib.util.find_spec(module) is None


@pytest.mark.parametrize("name", _PRIVATE)
def test_an_implementation_module_has_only_its_private_path(name):
    assert importlib.util.find_spec(f"estimators.learned.{name}") is None
    assert importlib.util.find_spec(f"estimators.learned._{name}") is not None


@pytest.mark.parametrize("name", sorted(learned.__all__))
def test_a_learned_name_has_one_public_path(name):
    value = getattr(learned, name)
    # The object says where it lives, a private module (no rewritten __module__): estimators.learned is its path.
    assert value.__module__.startswith("estimators.learned._")
    assert importlib.import_module(value.__module__).__dict__[name] is value
    assert not hasattr(estimators, name), f"estimators.{name}: a second public path"


@pytest.mark.parametrize("name", sorted(estimators.classical.__all__) + sorted(estimators.intervals.__all__))
def test_a_classical_or_interval_name_has_one_public_path(name):
    assert not hasattr(estimators, name), f"estimators.{name}: a second public path"


def test_the_face_holds_only_its_own_api():
    assert set(estimators.__all__) == _OWN
    methods = {n for n, v in vars(estimators).items() if inspect.isclass(v) and n.endswith("Inpainter")}
    assert methods == {"BaseInpainter"}
    with pytest.raises(AttributeError, match="estimators.learned"):
        estimators.UNetInpainter  # noqa: B018


def test_load_is_a_function_of_estimators_learned_not_a_module():
    assert inspect.isfunction(learned.load)
    assert "load" in learned.__all__ and not hasattr(estimators, "load")
    assert importlib.util.find_spec("estimators.learned.load") is None


#: inpaintenv names and their one public path: their home module, the only one whose ``__all__`` lists them.
_INPAINTENV_HOMES = {
    "UnfilledPixelsError": "inpaintenv.exceptions", "BadFrameError": "inpaintenv.exceptions",
    **{name: "inpaintenv.report.results" for name in ("EvaluationResult", "ID_COLUMNS", "METRIC_COLUMNS", "ROW_COLUMNS",
                                                       "json_safe", "merge_skipped", "parse_row", "skipped_markdown")},
}
#: The paths these names left: not offered there any more, not even as a stray attribute of a package's face.
_LEFT = {"inpaintenv.metrics": {"UnfilledPixelsError"}, "inpaintenv": {"EvaluationResult"},
         "inpaintenv.evaluate": {"ID_COLUMNS", "ROW_COLUMNS", "json_safe", "merge_skipped", "parse_row",
                                 "skipped_markdown"}}


def _public_inpaintenv_modules() -> list[str]:
    """Every public module of inpaintenv (no part of its name private), imported."""
    import inpaintenv

    names = ["inpaintenv"] + [info.name for info in pkgutil.walk_packages(inpaintenv.__path__, "inpaintenv.")
                              if not any(part.startswith("_") for part in info.name.split("."))]
    for name in names:
        importlib.import_module(name)
    return names


@pytest.mark.parametrize("name", sorted(_INPAINTENV_HOMES))
def test_an_inpaintenv_name_has_one_public_path(name):
    listed = [m for m in _public_inpaintenv_modules() if name in getattr(importlib.import_module(m), "__all__", ())]
    assert listed == [_INPAINTENV_HOMES[name]]


@pytest.mark.parametrize(("module", "name"), sorted((m, n) for m, names in _LEFT.items() for n in names))
def test_an_old_inpaintenv_path_is_gone(module, name):
    with pytest.raises(ImportError):
        exec(f"from {module} import {name}", {})
