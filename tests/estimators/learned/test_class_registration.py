"""One registration: every saveable learned class is registered by the mixin it derives from."""

from __future__ import annotations

import inspect
from pathlib import Path

import pytest

learned = pytest.importorskip("estimators.learned")

from estimators.learned import _checkpoint, _load  # noqa: E402,F401  (imports every family)
from estimators.learned._persistence import PersistenceMixin  # noqa: E402


def test_every_saveable_public_class_is_registered_by_its_name():
    saveable = {name for name in learned.__all__
                if inspect.isclass(value := getattr(learned, name)) and issubclass(value, PersistenceMixin)}
    assert saveable >= {"UNetInpainter", "AutoencoderInpainter", "PriorUNetInpainter", "BlendInpainter",
                        "ContextBlendInpainter", "ScanBlendInpainter", "MeanEnsembleInpainter"}
    assert set(_checkpoint.CLASSES) == saveable
    assert all(_checkpoint.CLASSES[name] is getattr(learned, name) for name in saveable)
    # The router holds two fitted methods and has no file of its own: never a checkpoint's class.
    assert not issubclass(learned.InputRoutedInpainter, PersistenceMixin)


def test_a_subclass_defined_elsewhere_does_not_take_a_shipped_name():
    before = dict(_checkpoint.CLASSES)

    class BlendInpainter(learned.BlendInpainter):  # a user's class of the same name
        pass

    assert _checkpoint.CLASSES == before


def test_no_module_registers_a_class_by_hand():
    folder = Path(learned.__file__).parent
    by_hand = [p.name for p in folder.glob("*.py") if "CLASSES.update" in p.read_text()
               or "CLASSES.setdefault" in p.read_text() or "CLASSES[" in p.read_text()]
    assert by_hand == ["_persistence.py"]
