"""``save`` / ``load``: one persistence mixin per family format, the shared checks of estimators/_persistence.py."""

from __future__ import annotations

import ast
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from sklearn.exceptions import NotFittedError

from estimators._persistence import as_path, check_loaded_class, check_options, read_or_fail, require_saveable
from estimators.intervals import ConformalIntervalInpainter
from estimators.intervals._persistence import CalibrationFileMixin
from inpaintenv.exceptions import InvalidInputError, InvalidTypeError
from inpaintenv.files import read_json, write_json

from stand_ins import FillTen

ROOT = Path(__file__).resolve().parents[2]


#: The one function face of the pairs: ``estimators.learned.load(path)``, any learned model (a
#: function, so that it lives where its name does); it may only call a pair's ``load``.
FACES = {"estimators/learned/_load.py:load"}


def _delegates(node: ast.FunctionDef) -> bool:
    """Whether ``node``'s body (after its docstring) is one ``return X.load(...)``."""
    body = node.body[1:] if ast.get_docstring(node) else node.body
    return (len(body) == 1 and isinstance(body[0], ast.Return) and isinstance(body[0].value, ast.Call)
            and isinstance(body[0].value.func, ast.Attribute) and body[0].value.func.attr == "load")


def _path_savers_and_loaders(root: Path) -> list[str]:
    """Every ``def save`` / ``def load`` under ``root``'s inpaintenv/ and estimators/ that takes a
    path (a runner's ``save(self)`` of its own state, or a local helper, is another thing), but
    a function face that only calls the pair."""
    found = []
    for folder in ("inpaintenv", "estimators"):
        for file in sorted((root / folder).rglob("*.py")):
            for node in ast.walk(ast.parse(file.read_text(), str(file))):
                if not (isinstance(node, ast.FunctionDef) and node.name in ("save", "load")):
                    continue
                where = f"{file.relative_to(root).as_posix()}:{node.name}"
                takes_path = "path" in [a.arg for a in node.args.posonlyargs + node.args.args]
                if takes_path and not (where in FACES and _delegates(node)):
                    found.append(where)
    return found


#: One ``save`` / ``load`` pair per family format, each on that family's persistence mixin.
PAIRS = ["estimators/intervals/_persistence.py:save", "estimators/intervals/_persistence.py:load",
         "estimators/learned/_persistence.py:save", "estimators/learned/_persistence.py:load"]


def test_one_save_load_pair_per_format_in_the_source():
    assert _path_savers_and_loaders(ROOT) == PAIRS


def test_the_scan_sees_a_second_pair_and_a_face_that_does_more(tmp_path):
    for folder in ("estimators/learned", "inpaintenv"):
        (tmp_path / folder).mkdir(parents=True)
    (tmp_path / "estimators" / "twin.py").write_text(
        "class A:\n    def save(self, path, **kw): ...\n\n    @classmethod\n    def load(cls, path): ...\n")
    (tmp_path / "inpaintenv" / "runner.py").write_text("class R:\n    def save(self): ...\n")
    face = tmp_path / "estimators" / "learned" / "_load.py"
    face.write_text('def load(path):\n    """Doc."""\n    return Base.load(path)\n')
    assert _path_savers_and_loaders(tmp_path) == ["estimators/twin.py:save", "estimators/twin.py:load"]
    face.write_text('def load(path):\n    """Doc."""\n    config = read(path)\n    return Base.load(config)\n')
    assert "estimators/learned/_load.py:load" in _path_savers_and_loaders(tmp_path)


def test_each_family_shares_its_format_pair():
    learned = pytest.importorskip("estimators.learned")
    from estimators.learned._persistence import PersistenceMixin

    for klass in (learned.UNetInpainter, learned.PriorUNetInpainter, learned.MeanEnsembleInpainter,
                  learned.ScanBlendInpainter):
        assert klass.save is PersistenceMixin.save
        assert klass.load.__func__ is PersistenceMixin.load.__func__
    assert ConformalIntervalInpainter.save is CalibrationFileMixin.save
    assert ConformalIntervalInpainter.load.__func__ is CalibrationFileMixin.load.__func__


@pytest.fixture(scope="module")
def wrapper() -> ConformalIntervalInpainter:
    rng = np.random.default_rng(0)
    truth = np.clip(10.0 + 2.0 * rng.standard_normal((4, 64, 96)), 0.1, None).astype(np.float32)
    return ConformalIntervalInpainter(FillTen(), signals=()).fit(truth, groups=["a", "a", "b", "b"])


def test_wrapper_round_trips_through_the_base(wrapper, tmp_path):
    path = wrapper.save(tmp_path / "cal.json")
    assert isinstance(path, Path) and read_json(path)["base"] == "FillTen"
    back = ConformalIntervalInpainter.load(str(path), estimator=FillTen())
    assert type(back) is ConformalIntervalInpainter and back.calibration_ == wrapper.calibration_
    assert back.quantile_ == wrapper.quantile_ and back.get_params()["signals"] == ()
    x = np.full((1, 64, 96), 10.0, np.float32)
    x[:, 10:20, 10:30] = np.nan
    for a, b in zip(back.predict_interval(x, 0.8), wrapper.predict_interval(x, 0.8)):
        np.testing.assert_array_equal(a, b)


def test_base_checks_options_path_and_fitted(wrapper, tmp_path):
    with pytest.raises(InvalidTypeError, match=r"ConformalIntervalInpainter.save\(\) got unexpected option.*'bse'.*base="):
        wrapper.save(tmp_path / "cal.json", bse="scanline")
    with pytest.raises(InvalidTypeError, match=r"load\(\) got unexpected option.*'base'.*estimator="):
        ConformalIntervalInpainter.load(tmp_path / "cal.json", base="scanline")
    with pytest.raises(InvalidTypeError, match="path must be a str or path-like, got int"):
        wrapper.save(3)
    with pytest.raises(NotFittedError, match="this ConformalIntervalInpainter is not fitted; call fit first"):
        ConformalIntervalInpainter(FillTen()).save(tmp_path / "unfitted.json")
    assert not (tmp_path / "unfitted.json").exists()
    with pytest.raises(InvalidInputError, match="missing.json"):
        ConformalIntervalInpainter.load(tmp_path / "missing.json", estimator=FillTen())


class _Note:
    """A toy family in the shape of the real ones: one JSON file recording its class, read by a plain
    function, the recorded class's ``_from_config`` building the object (over the shared checks)."""

    def __init__(self, value: float = 0.0) -> None:
        self.value = value

    def save(self, path: Any, **options: Any) -> Path:
        check_options(type(self), "save", options, ())
        target = as_path(path, f"{type(self).__name__}.save")
        require_saveable(self, self.value != 0.0)
        return write_json(target, {"class": type(self).__name__, "value": self.value})

    @classmethod
    def load(cls, path: Any, **options: Any) -> Any:
        check_options(cls, "load", options, ("scale",))
        source = as_path(path, f"{cls.__name__}.load")
        config = read_or_fail(lambda p: read_json(p, "note"), source, InvalidInputError)
        klass = {"_Note": _Note, "_LoudNote": _LoudNote, "_Other": _Other}[config["class"]]
        return check_loaded_class(cls, klass, source, InvalidInputError)._from_config(config, **options)

    @classmethod
    def _from_config(cls, config: dict[str, Any], scale: float = 1.0) -> Any:
        return cls(config["value"] * scale)


class _LoudNote(_Note):
    pass


class _Other(_Note):
    pass


def test_load_dispatches_on_the_recorded_class_and_refuses_another(tmp_path):
    path = _LoudNote(2.0).save(tmp_path / "note.json")
    back = _Note.load(path, scale=3.0)
    assert type(back) is _LoudNote and back.value == 6.0
    with pytest.raises(InvalidInputError, match=r"note.json holds a '_LoudNote', not a _Other"):
        _Other.load(path)
    with pytest.raises(NotFittedError, match="this _Note is not fitted"):
        _Note().save(tmp_path / "empty.json")


def test_an_unreadable_file_is_one_error_naming_it(tmp_path):
    with pytest.raises(InvalidInputError, match=r"note not found: .*absent.json$"):
        _Note.load(tmp_path / "absent.json")
    with pytest.raises(InvalidInputError, match="is a folder, not a file"):
        _Note.load(tmp_path)
    (tmp_path / "junk.json").write_text("{")
    with pytest.raises(InvalidInputError, match="junk.json"):
        _Note.load(tmp_path / "junk.json")
    assert json.loads(_Note(1.5).save(tmp_path / "ok.json").read_text())["value"] == 1.5


def test_interval_format_is_its_own_mixin():
    assert issubclass(ConformalIntervalInpainter, CalibrationFileMixin)
    assert CalibrationFileMixin._save_options == ("base",) and CalibrationFileMixin._load_options == ("estimator",)


#: Most classes of the project in a public estimator's MRO: the class, its family's base, the
#: parameter table, the training loop, its persistence mixin and BaseInpainter.
MAX_PROJECT_CLASSES = 6


def _project_classes(klass: type) -> list[str]:
    return [c.__name__ for c in klass.__mro__ if c.__module__.split(".")[0] in ("estimators", "inpaintenv")]


def _deep_classes(packages: tuple[str, ...]) -> dict[str, list[str]]:
    """Public class -> its project MRO, for every class of ``packages`` deeper than the limit."""
    import importlib
    import inspect

    deep = {}
    for package in packages:
        module = importlib.import_module(package)
        for name in module.__all__:
            obj = getattr(module, name)
            if inspect.isclass(obj) and len(_project_classes(obj)) > MAX_PROJECT_CLASSES:
                deep[f"{package}.{name}"] = _project_classes(obj)
    return deep


def test_no_public_estimator_holds_more_than_six_project_classes():
    pytest.importorskip("estimators.learned")
    packages = ("estimators.classical", "estimators.learned", "estimators.intervals")
    assert _deep_classes(packages) == {}
    learned = __import__("estimators.learned", fromlist=["UNetInpainter"])
    assert _project_classes(learned.UNetInpainter) == [
        "UNetInpainter", "_NeuralInpainter", "ConstrainedParams", "TrainingMixin", "PersistenceMixin", "BaseInpainter"]


def test_the_mro_check_sees_a_deeper_class(monkeypatch):
    import sys
    import types

    from estimators.base import BaseInpainter

    bases: list[type] = [BaseInpainter]
    for i in range(MAX_PROJECT_CLASSES):
        bases.append(type(f"_Layer{i}", (bases[-1],), {"__module__": "estimators.fake"}))
    fake = types.ModuleType("estimators.fake")
    fake.Deep = bases[-1]
    fake.__all__ = ["Deep"]
    monkeypatch.setitem(sys.modules, "estimators.fake", fake)
    assert list(_deep_classes(("estimators.fake",))) == ["estimators.fake.Deep"]
