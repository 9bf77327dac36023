"""The registry of methods by name (used by the CLI and the benchmark)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from param_values import param_values

from inpaintenv.registry import available_methods, get_spec, make_method, register_method

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
    """Older results stay re-runnable: each file in estimators/pretrained is a method."""
    pytest.importorskip("torch")
    from estimators.blend import DEFAULT_BLEND, PRETRAINED_DIR

    from inpaintenv.registry import PRETRAINED_RELEASES

    shipped = {p.stem for p in PRETRAINED_DIR.glob("*.json") if p.with_suffix(".safetensors").is_file()}
    assert set(PRETRAINED_RELEASES) == shipped
    est = make_method("kitti-rect-v1")
    assert est.get_params()["relative"] is False  # v1 predates the scale-free blend
    for name in PRETRAINED_RELEASES:  # each loads as the class its JSON names
        assert type(make_method(name)).__name__ == json.loads((PRETRAINED_DIR / f"{name}.json").read_text())["class"]
    from estimators.learned.releases import DEFAULT_RELEASE

    assert DEFAULT_BLEND in PRETRAINED_RELEASES  # the former default stays loadable by name
    for name in ("pretrained", "blend-pretrained", "unet-pretrained"):
        assert param_values(make_method(DEFAULT_RELEASE)) == param_values(make_method(name))


def test_aliases_resolve_to_the_canonical_name():
    from inpaintenv.registry import available_aliases, canonical_name, register_alias

    assert available_aliases()["unet-pretrained"] == "pretrained"
    assert available_aliases()["blend-pretrained"] == "pretrained"
    assert available_aliases()["unet-pretrained-mixed"] == "blend-pretrained-mixed"
    assert "unet-pretrained" not in available_methods() and "pretrained" in available_methods()
    assert get_spec("unet-pretrained") is get_spec("blend-pretrained") is get_spec("pretrained")
    assert get_spec("unet-pretrained-mixed").kwargs == {"name": "kitti-mixed-v1"}
    assert canonical_name("unet-pretrained") == "pretrained" and canonical_name("telea") == "telea"
    with pytest.raises(ValueError, match="already"):
        register_alias("telea", "ns")
    with pytest.raises(KeyError, match="no method"):
        register_alias("new-name", "not-a-method")


def test_suites_use_canonical_names():
    from inpaintenv.benchmark.suites import SUITES

    assert set(available_methods()) >= {n for names in SUITES.values() for n in names}
    assert "pretrained" in SUITES["default"] and "unet-pretrained" not in SUITES["default"]


def test_old_name_still_builds_the_shipped_blend():
    pytest.importorskip("torch")
    assert param_values(make_method("unet-pretrained")) == param_values(make_method("pretrained"))
    assert param_values(make_method("blend-pretrained")) == param_values(make_method("pretrained"))


def test_info_lists_aliases(capsys):
    from inpaintenv.cli import main

    assert main(["info", "--n-frames", "2", "--frame-shape", "32", "96", "--sample", "1"]) == 0
    out = capsys.readouterr().out
    assert "unet-pretrained -> pretrained" in out


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
