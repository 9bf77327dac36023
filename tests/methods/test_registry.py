"""The registry of methods by name (used by the CLI and the benchmark)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from param_values import param_values

from inpaintenv.methods.registry import available_methods, get_spec, make_method, register_method

EXPECTED = [
    "telea", "telea-hole", "ns", "ns-hole", "bilateral", "bilateral-hole", "ipbasic",
    "nearest", "harmonic", "scanline", "scanline-inverse", "constant",
]


def test_names_listed():
    assert set(EXPECTED) <= set(available_methods())
    assert get_spec("telea-hole").kwargs == {"fill": "hole"}
    assert get_spec("scanline-inverse").kwargs == {"inverse": True}


def test_unknown_name_lists_known_and_close_matches():
    with pytest.raises(KeyError, match="Did you mean 'telea'") as info:
        get_spec("telae")
    assert "ipbasic" in str(info.value)


def test_register_rejects_duplicates_and_bad_names():
    with pytest.raises(ValueError, match="already"):
        register_method("telea", "estimators.classical", "TeleaInpainter")
    with pytest.raises(ValueError, match="method names"):
        register_method("a:b", "m", "C")


def test_module_class_form_and_missing_module():
    spec = get_spec("collections:OrderedDict")
    assert (spec.module, spec.cls) == ("collections", "OrderedDict")
    with pytest.raises(ImportError, match="no_such_module"):
        make_method("no_such_module:Thing")
    with pytest.raises(ImportError, match="has no class"):
        make_method("collections:NoSuchClass")


@pytest.mark.parametrize("name", EXPECTED)
def test_every_classical_method_builds_and_fills(name):
    est = make_method(name)
    for key, value in get_spec(name).kwargs.items():
        assert est.get_params()[key] == value
    x = np.full((16, 24), 10.0, np.float32)
    x[4:10, 6:14] = np.nan
    out = est.predict(x)
    assert out.shape == x.shape and np.isfinite(out).all()


def test_overrides_and_bad_override():
    assert make_method("telea", radius=3).radius == 3
    with pytest.raises(TypeError, match="'telea'"):
        make_method("telea", no_such_param=1)


def test_every_shipped_release_has_its_own_method_name():
    """Each release in estimators/pretrained is a method, registered from its own JSON."""
    pytest.importorskip("torch")
    from inpaintenv.methods.learned import DEFAULT_RELEASE
    from inpaintenv.methods.learned import RELEASE_DIR as PRETRAINED_DIR
    from inpaintenv.methods.registry import PRETRAINED_RELEASES

    shipped = {p.stem for p in PRETRAINED_DIR.glob("*.json") if p.with_suffix(".safetensors").is_file()}
    assert set(PRETRAINED_RELEASES) == shipped == {"kitti-ensemble-v1", "kitti-mixed-v1", "kitti-scan-v1",
                                                   "kitti-sparse-v1"}
    for name in PRETRAINED_RELEASES:  # each loads as the class its JSON names, through the one factory
        assert get_spec(name).cls == "load_release" and get_spec(name).kwargs == {"name": name}
        assert type(make_method(name)).__name__ == json.loads((PRETRAINED_DIR / f"{name}.json").read_text())["class"]
    assert DEFAULT_RELEASE == "kitti-ensemble-v1"  # a map goes to the default release
    assert param_values(make_method(DEFAULT_RELEASE)) == param_values(make_method("pretrained").map_method)


def test_a_release_added_to_the_folder_is_listed(tmp_path):
    """No hand-kept list: the registry and the loader read the release folder (one function)."""
    from inpaintenv.methods.learned import shipped

    for name in ("kitti-mixed-v1", "kitti-new-v9"):
        (tmp_path / f"{name}.json").write_text(json.dumps({"class": "PriorUNetInpainter"}))
        (tmp_path / f"{name}.safetensors").write_bytes(b"")
    (tmp_path / "half-v1.json").write_text("{}")  # no weights beside it: not a release
    (tmp_path / "broken-v1.json").write_text("{")  # listed: loading it names the problem
    (tmp_path / "broken-v1.safetensors").write_bytes(b"")
    assert shipped(tmp_path) == {"broken-v1": "?", "kitti-mixed-v1": "PriorUNetInpainter",
                                 "kitti-new-v9": "PriorUNetInpainter"}


def test_aliases_resolve_to_the_canonical_name(monkeypatch):
    from inpaintenv.methods import registry
    from inpaintenv.methods.registry import available_aliases, canonical_name, register_alias

    monkeypatch.setitem(registry._ALIASES, "my-default", "pretrained")
    assert available_aliases()["my-default"] == "pretrained"
    assert "pretrained" in available_methods() and "blend-pretrained-mixed" in available_methods()
    assert get_spec("my-default") is get_spec("pretrained")
    assert get_spec("blend-pretrained-mixed").kwargs == {"name": "kitti-mixed-v1"}
    assert canonical_name("my-default") == "pretrained" and canonical_name("telea") == "telea"
    with pytest.raises(ValueError, match="already"):
        register_alias("telea", "ns")
    with pytest.raises(KeyError, match="no method"):
        register_alias("new-name", "not-a-method")


@pytest.mark.parametrize(("name", "instead"), [("unet-pretrained", "'pretrained'"),
                                               ("blend-pretrained", "not a blend; use 'pretrained'"),
                                               ("unet-pretrained-mixed", "'blend-pretrained-mixed'"),
                                               ("kitti-rect-v4", "releases-0.1"),
                                               ("kitti-context-v3", "releases-0.1")])
def test_removed_names_say_what_to_use(name, instead):
    """A name that loaded something else than it said (no U-Net), or a release that left the
    package, is one error naming what to use instead."""
    from inpaintenv.exceptions import UnknownNameError

    assert name not in available_methods()
    with pytest.raises(UnknownNameError, match=instead) as info:
        get_spec(name)
    assert "\n" not in str(info.value) and name in str(info.value)


def test_suites_use_canonical_names():
    from inpaintenv.benchmark.suites import SUITES

    assert set(available_methods()) >= {n for names in SUITES.values() for n in names}
    assert "pretrained" in SUITES["default"] and "blend-pretrained" not in SUITES["default"]


def test_info_lists_aliases(capsys, monkeypatch):
    from inpaintenv.cli import main
    from inpaintenv.methods import registry

    monkeypatch.setitem(registry._ALIASES, "my-default", "pretrained")

    assert main(["info", "--n-frames", "2", "--frame-shape", "32", "96", "--sample", "1"]) == 0
    out = capsys.readouterr().out
    assert "my-default -> pretrained" in out


_USER_MODULE = '''
import numpy as np

def my_function(x):
    return np.nan_to_num(x, nan=7.0)

class MyFill:
    def __init__(self, value=7.0):
        self.value = value

    def predict(self, x):
        return np.nan_to_num(x, nan=self.value)

my_estimator = MyFill(3.0)
'''


@pytest.fixture
def user_module(tmp_path, monkeypatch):
    """``mymodule.py`` in a fresh current folder that is not on the import path (as for the console script)."""
    import sys

    name = f"mymodule_{tmp_path.name.replace('-', '_')}"  # one module per test: no stale sys.modules entry
    (tmp_path / f"{name}.py").write_text(_USER_MODULE)
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "path", [p for p in sys.path if p not in ("", str(tmp_path))])
    yield name
    sys.modules.pop(name, None)


def test_module_attr_finds_the_current_folder_and_takes_a_plain_function(user_module, capsys):
    # The README says any callable is scored; -m mymodule:my_function failed twice: the current
    # folder was not on the import path, and the function was called with no depth
    # ("missing 1 required positional argument: 'x'").
    from inpaintenv.cli import main

    fn = make_method(f"{user_module}:my_function")
    assert fn.__name__ == "my_function"
    assert make_method(f"{user_module}:MyFill", value=2.0).value == 2.0  # a class is built with the overrides
    assert make_method(f"{user_module}:my_estimator").value == 3.0  # an object is the method itself
    with pytest.raises(TypeError, match="is a function, not a class, so it takes no parameters"):
        make_method(f"{user_module}:my_function", n_jobs=2)
    argv = ["evaluate", "-m", f"{user_module}:my_function", "-m", f"{user_module}:MyFill", "--synthetic",
            "--n-frames", "2", "--frame-shape", "32", "48", "--quiet"]
    assert main(argv) == 0, capsys.readouterr().err
    out = capsys.readouterr().out
    assert f"| {user_module}:my_function | rect-v1 | 2 |" in out and f"| {user_module}:MyFill | rect-v1 | 2 |" in out
