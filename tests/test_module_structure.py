"""The project's modules form no import circle, import only what the layer table allows, and stay small.

The import graph is read from the source, not from ``sys.modules``: every ``import`` /
``from ... import`` anywhere in a module (function-level ones too, since a deferred import
is still a dependency; imports under ``if TYPE_CHECKING:`` too, since a module that needs
another's names for its annotations still depends on it), every
``importlib.import_module("literal")``, and, in a module that calls ``import_module`` with
a computed name, every string constant naming a project module (absolute, or relative to
the module's package: the registry's table of method modules, a package's lazy exports).
An edge goes to the deepest project module the statement names (``from pkg import sub`` ->
``pkg.sub`` when ``sub`` is a module). A package's ``__init__`` is a node like any other;
the implicit import of a parent package by its submodules is not an edge (Python resolves
it first).

Size, in the packages and in ``perf/`` and ``experiments/`` (:data:`SIZED`): no
module over :data:`MAX_LINES` lines, with no way to opt out, and no function whose code
(its lines without the docstring: a numpydoc docstring documents, it does not make a
function do more) is over :data:`MAX_FUNCTION_LINES` lines, unless a comment on the line
above the ``def`` (or its decorators) says why: ``# long function: <reason>``.

Layout: the top of ``inpaintenv/`` holds at most :data:`MAX_LOOSE_MODULES` modules; the
rest live in packages named after their job; likewise the top of ``tests/`` holds at most
:data:`MAX_LOOSE_TEST_MODULES` test modules.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("inpaintenv", "estimators")
#: Folders whose modules the size limits cover: the packages and the scripts beside them.
SIZED = (*PACKAGES, "perf", "experiments")
MAX_LINES = 500
MAX_FUNCTION_LINES = 100
#: Parameters of an ``inpaintenv`` function: positional, and in all. More is a plan or options
#: object (``RunPlan``, ``FillOptions``, ``EvaluationPlan``) checked once where its values entered.
MAX_POSITIONAL, MAX_PARAMETERS = 12, 16
MAX_LOOSE_MODULES = 6
#: Test modules loose at the top of ``tests/``: the cross-cutting ones; the rest sit in
#: folders that mirror the package or job they test.
MAX_LOOSE_TEST_MODULES = 12
#: The comment that once let a module exceed MAX_LINES; spelled in two parts so that this
#: file does not hold it.
OPT_OUT = "# long " + "module:"


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


def _calls_import_module(node: ast.AST) -> bool:
    """Whether ``node`` is a call of ``importlib.import_module`` (or ``import_module``)."""
    if not isinstance(node, ast.Call):
        return False
    func = node.func
    return (isinstance(func, ast.Attribute) and func.attr == "import_module") or (
        isinstance(func, ast.Name) and func.id == "import_module")


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
    dynamic = any(_calls_import_module(n) for n in ast.walk(tree))
    for node in ast.walk(tree):
        targets: list[str] = []
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = _resolve(package, node.module or "", node.level, package)
            targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base for a in node.names]
        elif isinstance(node, ast.Call):
            target = _import_module_target(node, package)
            targets = [target] if target else []
        elif dynamic and isinstance(node, ast.Constant) and isinstance(node.value, str):
            # A computed import_module(...) reads its names from tables of strings.
            targets = [t for t in (node.value, f"{package}.{node.value}") if t in modules]
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
    assert "estimators.learned._checkpoint" in graph["estimators.learned._neural"]  # from . import _checkpoint as ckpt
    tree = ast.parse('import importlib\nimportlib.import_module("estimators.prior")\n'
                     'from importlib import import_module\nimport_module(".nets", "estimators")')
    calls = [n for n in ast.walk(tree) if isinstance(n, ast.Call)]
    assert [_import_module_target(c, "estimators") for c in calls] == ["estimators.prior", "estimators.nets"]
    typed = ast.parse("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from .evaluate import X\nimport os")
    assert {type(n).__name__ for n in ast.walk(typed) if id(n) in _type_checking_only(typed)} >= {"ImportFrom"}
    # Typing-only imports are edges, and so are the module names a computed import_module reads.
    assert "estimators.learned._neural" in graph["estimators.learned"]  # lazy exports: {"UNetInpainter": "_neural"}
    assert "estimators.learned" in graph["inpaintenv.methods.registry"]  # MethodSpec("estimators.learned", ...)


def test_typing_only_imports_are_edges(tmp_path):
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from .b import B\n")
    (pkg / "b.py").write_text("from . import a\n")
    modules = {"pkg": pkg / "__init__.py", "pkg.a": pkg / "a.py", "pkg.b": pkg / "b.py"}
    graph = {name: imports_of(name, path, modules) for name, path in modules.items()}
    assert find_cycle(graph) == ["pkg.a", "pkg.b", "pkg.a"]


def test_find_cycle_reports_the_circle():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": set()}) is None


def test_no_import_circles():
    cycle = find_cycle(import_graph())
    assert cycle is None, "import circle: " + " -> ".join(cycle or [])


#: The layers that know methods by name (ARCHITECTURE.md): the only importers of the registry.
REGISTRY_USERS = ("inpaintenv.benchmark", "inpaintenv.cli", "inpaintenv.filling")
#: Importers of the registry outside those layers, each waiting for its fix (none open).
REGISTRY_KNOWN_OPEN: set[str] = set()


def test_only_the_layers_that_list_methods_import_the_registry():
    graph = import_graph()
    users = {m for m, deps in graph.items() if "inpaintenv.methods.registry" in deps}
    outside = {m for m in users if not m.startswith(REGISTRY_USERS)}
    assert outside == REGISTRY_KNOWN_OPEN, (
        f"only {REGISTRY_USERS} may import inpaintenv.methods.registry; also imported by "
        f"{sorted(outside - REGISTRY_KNOWN_OPEN)} (drop a fixed one from REGISTRY_KNOWN_OPEN: "
        f"{sorted(REGISTRY_KNOWN_OPEN - outside)})")
    # estimators read the classical table without the registry: neither the table nor the
    # package's __init__ (which importing the table runs) imports anything of the project.
    assert not graph["inpaintenv.methods.classical"] and not graph["inpaintenv.methods"]


def _has_reason(lines: list[str], line: int, marker: str) -> bool:
    """Whether the comment ``# <marker>: <reason>`` is on the line above ``line`` (1-based)."""
    above = lines[line - 2].strip() if line >= 2 else ""
    return above.startswith(f"# {marker}:") and len(above) > len(f"# {marker}:") + 3


def long_modules(paths: list[Path]) -> dict[str, int]:
    """Modules over MAX_LINES lines, whatever their comments say."""
    out = {}
    for p in paths:
        n = len(p.read_text().splitlines())
        if n > MAX_LINES:
            out[str(p.relative_to(ROOT)) if p.is_relative_to(ROOT) else str(p)] = n
    return out


def opt_outs(paths: list[Path]) -> list[str]:
    """``path:line`` of every line of ``paths`` that starts with the retired module opt-out."""
    return [f"{p.relative_to(ROOT) if p.is_relative_to(ROOT) else p}:{i}"
            for p in paths for i, line in enumerate(p.read_text().splitlines(), 1)
            if line.lstrip().startswith(OPT_OUT)]


def loose_modules(package: Path) -> list[str]:
    """Modules directly in ``package`` (not in a subpackage), ``__init__.py`` aside."""
    return sorted(p.name for p in package.glob("*.py") if p.name != "__init__.py")


def long_functions(path: Path) -> dict[str, int]:
    """``module:function`` -> code lines of every function over MAX_FUNCTION_LINES without a reason."""
    text = path.read_text()
    lines = text.splitlines()
    out = {}
    for node in ast.walk(ast.parse(text, str(path))):
        if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        size = node.end_lineno - node.lineno + 1
        first = node.body[0]
        if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) and isinstance(first.value.value, str):
            size -= first.end_lineno - first.lineno + 1  # the docstring documents; it is not code
        start = min([node.lineno, *(d.lineno for d in node.decorator_list)])
        if size > MAX_FUNCTION_LINES and not _has_reason(lines, start, "long function"):
            out[f"{path.name}:{node.name} (line {node.lineno})"] = size
    return out


def _py(folder: str) -> list[Path]:
    return sorted((ROOT / folder).rglob("*.py"))


@pytest.mark.parametrize("folder", SIZED)
def test_no_module_over_500_lines(folder):
    long = long_modules(_py(folder))
    assert not long, f"modules over {MAX_LINES} lines (split them by job): {long}"


def test_no_module_opts_out_of_the_size_limit():
    found = opt_outs([p for folder in (*SIZED, "tests") for p in _py(folder)])
    assert not found, f"module opt-outs ({OPT_OUT!r}) are retired; split the module instead: {found}"


@pytest.mark.parametrize("folder", SIZED)
def test_no_function_over_100_lines(folder):
    long = {k: v for p in _py(folder) for k, v in long_functions(p).items()}
    assert not long, (f"functions of over {MAX_FUNCTION_LINES} lines of code (split them by job, or say why on the "
                      f"line above the def: '# long function: ...'): {long}")


def long_signatures(path: Path) -> dict[str, tuple[int, int]]:
    """``module:function`` -> (positional, all) parameters (``self``/``cls`` aside) of every function with more
    than MAX_POSITIONAL positional or MAX_PARAMETERS in all."""
    out = {}
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            args = node.args
            positional = [a for a in (*args.posonlyargs, *args.args) if a.arg not in ("self", "cls")]
            n_all = len(positional) + len(args.kwonlyargs)
            if len(positional) > MAX_POSITIONAL or n_all > MAX_PARAMETERS:
                out[f"{path.name}:{node.name} (line {node.lineno})"] = (len(positional), n_all)
    return out


def test_no_function_takes_a_long_list_of_parameters(tmp_path):
    found = {k: v for p in _py("inpaintenv") for k, v in long_signatures(p).items()}
    assert not found, (f"functions taking over {MAX_POSITIONAL} positional or {MAX_PARAMETERS} parameters (pass one "
                       f"plan or options object, checked once where its values enter): {found}")
    many = ", ".join(f"a{i}" for i in range(MAX_POSITIONAL + 1))
    (tmp_path / "m.py").write_text(f"def run({many}): pass\n\ndef ok(self, {many[4:]}): pass\n\n"
                                   f"def fill(a, *, {', '.join(f'k{i}=0' for i in range(MAX_PARAMETERS))}): pass\n")
    assert list(long_signatures(tmp_path / "m.py")) == ["m.py:run (line 1)", "m.py:fill (line 5)"]


def test_size_checks_see_long_code_and_accept_written_reasons_for_functions_only(tmp_path):
    body = "".join(f"    x{i} = {i}\n" for i in range(MAX_FUNCTION_LINES + 1))
    doc = '    """' + "doc\n" * 200 + '    """\n'
    (tmp_path / "m.py").write_text(f"def long():\n{body}\n\ndef documented():\n{doc}    return 1\n\n"
                                   f"# long function: one table of constants, read top to bottom\n"
                                   f"@staticmethod\ndef explained():\n{body}")
    assert list(long_functions(tmp_path / "m.py")) == ["m.py:long (line 1)"]
    (tmp_path / "big.py").write_text("x = 1\n" * (MAX_LINES + 1))
    (tmp_path / "excused.py").write_text(f"{OPT_OUT} generated table\n" + "x = 1\n" * (MAX_LINES + 1))
    (tmp_path / "ok.py").write_text("x = 1\n" * MAX_LINES)
    paths = [tmp_path / "big.py", tmp_path / "excused.py", tmp_path / "ok.py"]
    assert list(long_modules(paths)) == [str(tmp_path / "big.py"), str(tmp_path / "excused.py")]
    assert opt_outs(paths) == [f"{tmp_path / 'excused.py'}:1"]


def test_loose_modules_counts_modules_not_packages_nor_init(tmp_path):
    (tmp_path / "__init__.py").write_text("")
    (tmp_path / "a.py").write_text("")
    (tmp_path / "_b.py").write_text("")
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "__init__.py").write_text("")
    (tmp_path / "sub" / "c.py").write_text("")
    (tmp_path / "notes.md").write_text("")
    assert loose_modules(tmp_path) == ["_b.py", "a.py"]


def test_inpaintenv_root_shows_its_rooms():
    loose = loose_modules(ROOT / "inpaintenv")
    assert len(loose) <= MAX_LOOSE_MODULES, (
        f"{len(loose)} modules loose at the top of inpaintenv/ (at most {MAX_LOOSE_MODULES}; group them into "
        f"packages by job): {loose}")


def test_tests_root_holds_only_the_cross_cutting_tests():
    loose = sorted(p.name for p in (ROOT / "tests").glob("test_*.py"))
    assert len(loose) <= MAX_LOOSE_TEST_MODULES, (
        f"{len(loose)} test modules loose at the top of tests/ (at most {MAX_LOOSE_TEST_MODULES}; move the ones "
        f"that test one package or job into the folder that mirrors it): {loose}")


def test_test_modules_have_distinct_names():
    # The tests folders have no __init__.py, so pytest imports each test module by its file
    # name: two of one name in different folders stop the whole run at collection.
    seen: dict[str, Path] = {}
    clashes = []
    for path in sorted((ROOT / "tests").rglob("test_*.py")):
        if path.name in seen:
            clashes.append(f"{seen[path.name].relative_to(ROOT)} and {path.relative_to(ROOT)}")
        seen.setdefault(path.name, path)
    assert not clashes, "test modules sharing a name: " + "; ".join(clashes)


MAP_PAGE = ROOT / "docs" / "reference" / "README.md"


def layer_table(text: str) -> dict[str, set[str]]:
    """Unit -> the units it imports, from the fenced block after "The layers, bottom up" in the code map.

    A line is ``unit  a, b, c`` (``-`` for none); a unit is ``name/`` (a package of
    ``inpaintenv``), ``name.py`` (a loose module) or ``estimators`` (the methods' package).
    """
    start = text.index("The layers, bottom up")
    block = text[start:].split("```text\n", 1)[1].split("```", 1)[0]
    out: dict[str, set[str]] = {}
    for line in block.splitlines():
        unit, _, rest = line.strip().partition(" ")
        rest = rest.strip()
        out[unit] = set() if rest == "-" else {u.strip() for u in rest.split(",")}
    return out


def unit_of(module: str) -> str:
    """The layer-table unit of a dotted module name (see :func:`layer_table`)."""
    parts = module.split(".")
    if parts[0] != "inpaintenv":
        return parts[0]
    if len(parts) == 1:
        return "__init__.py"
    return f"{parts[1]}/" if (ROOT / "inpaintenv" / parts[1]).is_dir() else f"{parts[1]}.py"


def unit_graph() -> dict[str, set[str]]:
    """Unit -> the other units its modules import, for every unit of ``inpaintenv``."""
    out: dict[str, set[str]] = {}
    for module, deps in import_graph().items():
        if module.startswith("inpaintenv"):
            unit = unit_of(module)
            out.setdefault(unit, set()).update(unit_of(d) for d in deps if unit_of(d) != unit)
    return out


def test_layer_table_reads_units_and_their_imports():
    text = "The layers, bottom up: ...\n\n```text\nfiles/    exceptions.py\nexceptions.py  -\ncli/  a/, estimators\n```\n"
    assert layer_table(text) == {"files/": {"exceptions.py"}, "exceptions.py": set(), "cli/": {"a/", "estimators"}}


def test_the_layer_table_is_the_import_graph():
    declared = layer_table(MAP_PAGE.read_text(encoding="utf-8"))
    actual = {unit: deps for unit, deps in unit_graph().items() if unit != "_version.py"}
    undeclared = {u: sorted(d - declared.get(u, set())) for u, d in actual.items() if d - declared.get(u, set())}
    assert not undeclared, (
        f"imports the layer table of {MAP_PAGE.relative_to(ROOT)} does not list (add the arrow there if it is "
        f"meant, or import the other way): {undeclared}")
    stale = {u: sorted(d - actual.get(u, set())) for u, d in declared.items() if d - actual.get(u, set())}
    assert not stale, f"arrows in {MAP_PAGE.relative_to(ROOT)}'s layer table that no import makes: {stale}"
    missing = sorted(set(actual) - set(declared) - {"_version.py"})
    assert not missing, f"units of inpaintenv/ missing from the layer table: {missing}"


#: The only units of ``inpaintenv`` that import ``estimators``: the registry builds a
#: method by module name, and ``train`` reads the training recipes.
ESTIMATORS_IMPORTERS = {"inpaintenv.methods.registry", "inpaintenv.cli.train"}
#: The only modules below ``cli/`` that import ``benchmark/``: a scored submission is
#: written as a benchmark run folder.
BENCHMARK_IMPORTERS = {"inpaintenv.submission.score"}


def test_the_benchmark_stays_method_agnostic():
    graph = import_graph()
    up = {m for m, deps in graph.items() if m.startswith("inpaintenv") and any(d.startswith("estimators") for d in deps)}
    assert up == ESTIMATORS_IMPORTERS, f"modules of inpaintenv importing estimators: {sorted(up)}"


def test_features_and_infrastructure_do_not_import_the_benchmark():
    graph = import_graph()
    below = {m for m, deps in graph.items()
             if m.startswith("inpaintenv") and not m.startswith(("inpaintenv.benchmark", "inpaintenv.cli"))
             and any(d.startswith("inpaintenv.benchmark") for d in deps)}
    assert below == BENCHMARK_IMPORTERS, (
        f"modules below the benchmark importing it (the lock, identity and ledger live in files/): {sorted(below)}")


def python_files() -> list[Path]:
    """Every Python file of the repository (packages, scripts, tests, docs), none under a hidden folder."""
    return [p for p in sorted(ROOT.rglob("*.py")) if not any(part.startswith(".") for part in p.relative_to(ROOT).parts)]


def definitions_of(name: str, paths: list[Path], root: Path = ROOT) -> list[str]:
    """``path:line`` of every function named ``name`` (at any depth) in ``paths``."""
    return [f"{p.relative_to(root).as_posix()}:{n.lineno}" for p in paths
            for n in ast.walk(ast.parse(p.read_text(), str(p)))
            if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef)) and n.name == name]


def test_definitions_of_sees_methods_nested_and_async_functions(tmp_path):
    (tmp_path / "a.py").write_text("class A:\n    def make_method(self):\n        async def make_method():\n"
                                   "            pass\n\n\ndef other():\n    pass\n")
    assert definitions_of("make_method", [tmp_path / "a.py"], tmp_path) == ["a.py:2", "a.py:3"]


def test_one_make_method():
    """``make_method`` is the registry's; a helper that builds a method for one job has its own name."""
    found = [d.rpartition(":")[0] for d in definitions_of("make_method", python_files())]
    assert found == ["inpaintenv/methods/registry.py"], f"functions named make_method: {found}"


def _owner(module: str) -> str:
    """The package whose modules alone may use ``module``'s private parts: the package
    above its first private part (``a.b._c.d`` -> ``a.b``); "" when it has none."""
    parts = module.split(".")
    for i, part in enumerate(parts):
        if part.startswith("_") and not part.startswith("__"):
            return ".".join(parts[:i])
    return ""


def private_imports(name: str, path: Path, modules: dict[str, Path]) -> list[str]:
    """What ``name`` imports that is private to another package (see :func:`test_no_private_cross_module_import`)."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    bad: list[str] = []
    for target in sorted(imports_of(name, path, modules)):
        owner = _owner(target)
        if owner and not (package == owner or package.startswith(owner + ".")):
            bad.append(f"{name} imports the private module {target}")
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if not isinstance(node, ast.ImportFrom):
            continue
        base = _resolve(package, node.module or "", node.level, package)
        if base.partition(".")[0] not in {m.partition(".")[0] for m in modules}:
            continue  # another project's names
        home = base if base not in modules or modules[base].name == "__init__.py" else base.rpartition(".")[0]
        for alias in node.names:
            private = alias.name.startswith("_") and not alias.name.startswith("__")
            if private and f"{base}.{alias.name}" not in modules and home != package:
                bad.append(f"{name} imports {alias.name} from {base}")
    return bad


def test_private_imports_sees_names_and_modules_across_packages(tmp_path):
    files = {"p/__init__.py": "", "p/_m.py": "def _f(): pass\n", "p/a.py": "from ._m import _f\n",
             "p/sub/__init__.py": "", "p/sub/b.py": "from .._m import g\nfrom .. import _m\n",
             "p/sub/c.py": "from .._m import _f\n", "q/__init__.py": "", "q/d.py": "from p._m import g\nimport p._m\n"}
    for rel, text in files.items():
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_text(text)
    modules = {".".join(Path(rel).with_suffix("").parts).removesuffix(".__init__"): tmp_path / rel for rel in files}
    found = {m: private_imports(m, modules[m], modules) for m in modules}
    assert found["p.a"] == [] and found["p.sub.b"] == []  # a package's own private module, from anywhere inside it
    assert found["p.sub.c"] == ["p.sub.c imports _f from p._m"]  # a private name, from another package
    assert found["q.d"] == ["q.d imports the private module p._m"]


def test_no_private_cross_module_import():
    """A private name is no other package's API.

    The rule: a private name (``_x``, not a dunder) may be imported only by a module of the
    package that defines it (``from ._m import _x`` between siblings, or from the package's
    ``__init__``); a private module (``pkg/_m.py``) only by modules inside ``pkg`` (its
    subpackages included: ``estimators._constraints`` is the estimators' shared machinery).
    What another package needs is public (``Predictor``, ``EvaluationPlan``), and imported
    through its public path. Scripts and tests (``perf/``, ``tests/``) are not checked.
    """
    modules = project_modules()
    bad = [line for name, path in modules.items() for line in private_imports(name, path, modules)]
    assert bad == [], "private names used across packages (make them public or keep them home):\n" + "\n".join(bad)
