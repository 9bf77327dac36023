"""The project's modules form no import circle and stay small (issue 18).

The import graph is read from the source, not from ``sys.modules``: every ``import`` /
``from ... import`` anywhere in a module (function-level ones too, since a deferred import
is still a dependency) and every ``importlib.import_module("literal")``. An edge goes to
the deepest project module the statement names (``from pkg import sub`` -> ``pkg.sub`` when
``sub`` is a module). A package's ``__init__`` is a node like any other; the implicit
import of a parent package by its submodules is not an edge (Python resolves it first).
Imports under ``if TYPE_CHECKING:`` are left out: they never run, and a type annotation
naming a class of the module that imports this one is not a dependency at import time.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("inpaintenv", "estimators")
MAX_LINES = 500


def project_modules() -> dict[str, Path]:
    """Dotted module name -> file, for every module of the project's packages."""
    out: dict[str, Path] = {}
    for pkg in PACKAGES:
        for path in sorted((ROOT / pkg).rglob("*.py")):
            parts = list(path.relative_to(ROOT).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            out[".".join(parts)] = path
    return out


def _resolve(module: str, name: str, level: int, package: str) -> str:
    """Absolute dotted name of ``from <level dots><name> import ...`` inside ``package``."""
    if level == 0:
        return name
    base = package.split(".")
    base = base[: len(base) - (level - 1)]
    return ".".join([*base, name] if name else base)


def _import_module_target(call: ast.Call, package: str) -> str | None:
    """The module a static ``importlib.import_module("x"[, package])`` call imports."""
    func = call.func
    named = (isinstance(func, ast.Attribute) and func.attr == "import_module") or (
        isinstance(func, ast.Name) and func.id == "import_module"
    )
    if not named or not call.args or not isinstance(call.args[0], ast.Constant) or not isinstance(call.args[0].value, str):
        return None
    target = call.args[0].value
    if target.startswith("."):
        level = len(target) - len(target.lstrip("."))
        return _resolve(package, target[level:], level, package)
    return target


def _type_checking_only(tree: ast.AST) -> set[int]:
    """ids of the nodes inside ``if TYPE_CHECKING:`` (or ``typing.TYPE_CHECKING``) blocks."""
    skip: set[int] = set()
    for node in ast.walk(tree):
        test = getattr(node, "test", None)
        if isinstance(node, ast.If) and (
            (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING")
            or (isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")
        ):
            skip |= {id(n) for stmt in node.body for n in ast.walk(stmt)}
    return skip


def imports_of(name: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """Project modules that ``name`` imports (see the module docstring)."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: set[str] = set()
    tree = ast.parse(path.read_text(), str(path))
    typing_only = _type_checking_only(tree)
    for node in ast.walk(tree):
        if id(node) in typing_only:
            continue
        targets: list[str] = []
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = _resolve(package, node.module or "", node.level, package)
            targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base for a in node.names]
        elif isinstance(node, ast.Call):
            target = _import_module_target(node, package)
            targets = [target] if target else []
        for target in targets:
            # `import a.b.c` names a.b.c; keep the deepest part that is a project module.
            while target and target not in modules:
                target = target.rpartition(".")[0]
            if target and target != name:
                found.add(target)
    return found


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One import circle as a list of modules (first == last), or None."""
    state: dict[str, int] = {}  # 1 = on the current path, 2 = done
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                return [*stack[stack.index(nxt):], nxt]
            if nxt not in state and (cycle := visit(nxt)):
                return cycle
        stack.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state and (cycle := visit(node)):
            return cycle
    return None


def import_graph() -> dict[str, set[str]]:
    modules = project_modules()
    return {name: imports_of(name, path, modules) for name, path in modules.items()}


def test_graph_sees_static_imports_and_import_module_literals():
    graph = import_graph()
    assert "inpaintenv.conventions" in graph["estimators.base"]  # from inpaintenv.conventions import ...
    assert "estimators.learned._checkpoint" in graph["estimators.learned.neural"]  # from . import _checkpoint as ckpt
    tree = ast.parse('import importlib\nimportlib.import_module("estimators.prior")\n'
                     'from importlib import import_module\nimport_module(".nets", "estimators")')
    calls = [n for n in ast.walk(tree) if isinstance(n, ast.Call)]
    assert [_import_module_target(c, "estimators") for c in calls] == ["estimators.prior", "estimators.nets"]
    typed = ast.parse("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from .evaluate import X\nimport os")
    assert {type(n).__name__ for n in ast.walk(typed) if id(n) in _type_checking_only(typed)} >= {"ImportFrom"}


def test_find_cycle_reports_the_circle():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": set()}) is None


def test_no_import_circles():
    cycle = find_cycle(import_graph())
    assert cycle is None, "import circle: " + " -> ".join(cycle or [])


@pytest.mark.parametrize("package", PACKAGES)
def test_no_module_over_500_lines(package):
    long = {str(p.relative_to(ROOT)): n for p in (ROOT / package).rglob("*.py")
            if (n := len(p.read_text().splitlines())) > MAX_LINES}
    assert not long, f"modules over {MAX_LINES} lines (split them by job): {long}"
