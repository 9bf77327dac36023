"""One list of loadable classes: every saveable public learned class is known to ``load``, with
no import made only for its side effect, and each loads from a checkpoint it saved."""

from __future__ import annotations

import inspect
import re
from pathlib import Path

import pytest

learned = pytest.importorskip("estimators.learned")

from estimators.learned import _load  # noqa: E402
from estimators.learned._checkpoint import CheckpointError  # noqa: E402
from estimators.learned._persistence import PersistenceMixin, defined_classes  # noqa: E402

@pytest.fixture(scope="module")
def tiny_fitted():
    """A function: class name -> one small fitted instance of it (fitted once per module)."""
    from inpaintenv.data import SyntheticStreets

    maps = SyntheticStreets(n=4, frame_shape=(32, 64), frames_per_drive=2)
    scans = SyntheticStreets(n=2, seed=1, frame_shape=(64, 160), input="scan")
    blend = dict(width=4, layers=1, epochs=1, masks_per_frame=1, pixels_per_frame=100, batch_pixels=64, num_threads=1)
    build = {
        "UNetInpainter": lambda: learned.UNetInpainter(width=4, depth=1, batch_size=2, max_steps=1, random_state=0,
                                                       num_threads=1).fit(maps),
        "AutoencoderInpainter": lambda: learned.AutoencoderInpainter(width=4, depth=1, batch_size=2, max_steps=1,
                                                                     random_state=0, num_threads=1).fit(maps),
        "PriorUNetInpainter": lambda: learned.PriorUNetInpainter(width=4, levels=1, batch_size=2, max_steps=1,
                                                                 random_state=0, num_threads=1).fit(maps),
        "BlendInpainter": lambda: learned.BlendInpainter(**blend).fit(maps),
        "ContextBlendInpainter": lambda: learned.ContextBlendInpainter(
            n_context=2, context_widths=(4, 4), width=4, layers=1, epochs=1, masks_per_frame=1, keep=(1.0,),
            pixels_per_frame=50, batch_frames=2, batch_pixels=32, num_threads=1).fit(maps),
        "ScanBlendInpainter": lambda: learned.ScanBlendInpainter(near_distance=2.0, epochs=1, pixels_per_frame=100,
                                                                 width=4).fit(scans),
        "SparseResidualInpainter": lambda: learned.SparseResidualInpainter(rings=(1,), epochs=1, pixels_per_frame=100,
                                                                           width=4).fit(scans),
        "MeanEnsembleInpainter": lambda: learned.MeanEnsembleInpainter.from_fitted(
            [("first", made("BlendInpainter")), ("second", made("UNetInpainter"))]),
    }
    cache: dict = {}

    def made(name: str):
        if name not in cache:
            cache[name] = build[name]()
        return cache[name]

    return made


SAVEABLE = sorted(name for name in learned.__all__
                  if inspect.isclass(value := getattr(learned, name)) and issubclass(value, PersistenceMixin))


def test_load_lists_every_saveable_public_class():
    assert set(SAVEABLE) >= {"UNetInpainter", "AutoencoderInpainter", "PriorUNetInpainter", "BlendInpainter",
                             "ContextBlendInpainter", "ScanBlendInpainter", "SparseResidualInpainter",
                             "MeanEnsembleInpainter"}
    assert set(_load.LOADABLE) == set(SAVEABLE)
    assert all(_load.LOADABLE[name] is getattr(learned, name) for name in SAVEABLE)
    assert {name: defined_classes()[name] for name in SAVEABLE} == _load.LOADABLE
    # The router holds two fitted methods and has no file of its own: never a checkpoint's class.
    assert not issubclass(learned.InputRoutedInpainter, PersistenceMixin)


@pytest.mark.parametrize("name", SAVEABLE)
def test_every_saveable_class_loads_from_a_checkpoint_it_saved(name, tiny_fitted, tmp_path):
    est = tiny_fitted(name)
    path = est.save(tmp_path / name)
    again = learned.load(path)
    assert type(again) is type(est)
    assert type(getattr(learned, name).load(path)) is type(est)


def test_a_subclass_defined_elsewhere_does_not_take_a_shipped_name(tiny_fitted, tmp_path):
    class BlendInpainter(learned.BlendInpainter):  # a user's class of the same name
        pass

    assert defined_classes()["BlendInpainter"] is learned.BlendInpainter
    path = tiny_fitted("BlendInpainter").save(tmp_path / "blend")
    assert type(learned.load(path)) is learned.BlendInpainter


def test_a_class_this_version_does_not_know_is_one_error(tiny_fitted, tmp_path):
    import json

    path = tiny_fitted("BlendInpainter").save(tmp_path / "blend")
    config = json.loads((path / "config.json").read_text())
    config["class"] = "NoSuchInpainter"
    (path / "config.json").write_text(json.dumps(config))
    with pytest.raises(CheckpointError, match="NoSuchInpainter"):
        learned.load(path)


def test_no_family_is_imported_only_for_its_side_effect():
    # A family imported unused (so that its classes exist) is the kind of import a new family forgets.
    families = {klass.__module__.rpartition(".")[2] for klass in _load.LOADABLE.values()}
    folder = Path(learned.__file__).parent
    unused = re.compile(r"^\s*from \. import (?P<names>[\w, ]+?)\s*# noqa: F401", re.MULTILINE)
    found = [f"{p.name}: {m.group('names')}" for p in sorted(folder.rglob("*.py")) for m in unused.finditer(p.read_text())
             if families & {n.strip() for n in m.group("names").split(",")}]
    assert found == []


def test_a_load_reaches_the_class_own_from_config_in_three_hops(tiny_fitted, tmp_path, monkeypatch):
    """``load`` -> ``PersistenceMixin.load`` (reads the folder with ``read_model``) -> ``from_config`` -> the
    recorded class's ``_from_config``, for a model and for each member of an ensemble."""
    chains: list[list[str]] = []

    def recording(klass):
        original = klass._from_config.__func__

        def _from_config(cls, config, weights, where):
            names = []
            for frame in inspect.stack()[1:]:
                if frame.function.startswith("test_"):
                    break
                if frame.filename != __file__:  # not this wrapper
                    names.append(f"{Path(frame.filename).name}:{frame.function}")
            chains.append(names[::-1])
            return original(cls, config, weights, where)

        monkeypatch.setattr(klass, "_from_config", classmethod(_from_config))

    for klass in (learned.UNetInpainter, learned.BlendInpainter, learned.MeanEnsembleInpainter):
        recording(klass)
    learned.load(tiny_fitted("UNetInpainter").save(tmp_path / "unet"))
    entry = ["_load.py:load", "_persistence.py:load", "_persistence.py:from_config"]
    assert chains == [entry]
    chains.clear()
    learned.load(tiny_fitted("MeanEnsembleInpainter").save(tmp_path / "ensemble"))
    member = [*entry, "_ensemble.py:_from_config", "_persistence.py:from_config"]
    assert chains == [entry, member, member]  # the ensemble, then each of its two members
