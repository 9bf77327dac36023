"""experiments/ holds only scripts its README maps to what they reproduce, on the public API."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

EXPERIMENTS = Path(__file__).resolve().parents[2] / "experiments"
SCRIPTS = sorted(p for p in EXPERIMENTS.iterdir() if p.suffix in (".py", ".sh") and p.name != "_common.py")
#: The one shared module of the scripts (a script never imports another script).
SHARED = "_common"
#: Scripts at most: one per job (jobs on the same models or frames are commands of one script).
MAX_SCRIPTS = 8


def named_in_readme() -> set[str]:
    """Script names in the first column of the README's tables."""
    text = (EXPERIMENTS / "README.md").read_text()
    return set(re.findall(r"^\| `([\w.]+\.(?:py|sh))` \|", text, flags=re.MULTILINE))


def imported_modules(path: Path) -> list[str]:
    """Every module ``path`` imports, at any depth of its code."""
    names = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module:
            names.append(node.module)
    return names


def offending_imports(path: Path) -> list[str]:
    """Imports of ``path`` that reach another script or a private module of the package."""
    siblings = {p.stem for p in EXPERIMENTS.glob("*.py")} - {SHARED}
    return [m for m in imported_modules(path)
            if m in siblings
            or (m != SHARED and any(part.startswith("_") and part != "__future__" for part in m.split(".")))]


def test_at_most_eight_scripts():
    assert len(SCRIPTS) <= MAX_SCRIPTS, (f"{len(SCRIPTS)} scripts in experiments/ (at most {MAX_SCRIPTS}: merge those "
                                         f"that do one job behind commands): {[p.name for p in SCRIPTS]}")


def test_readme_maps_every_script_and_names_only_scripts_that_exist():
    assert named_in_readme() == {p.name for p in SCRIPTS}


@pytest.mark.parametrize("script", [p for p in SCRIPTS if p.suffix == ".py"] + [EXPERIMENTS / "_common.py"],
                         ids=lambda p: p.name)
def test_scripts_import_only_public_api_and_the_shared_module(script):
    assert offending_imports(script) == []


def test_the_check_catches_a_sibling_script_and_a_private_module(tmp_path, monkeypatch):
    bad = tmp_path / "bad.py"
    bad.write_text("from nested_mean import Memo\nfrom estimators.learned._checkpoint import CheckpointError\n"
                   "from _common import sel_scores\nfrom __future__ import annotations\n")
    assert offending_imports(bad) == ["nested_mean", "estimators.learned._checkpoint"]
