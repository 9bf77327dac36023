"""The code map in docs/reference/README.md names every package and loose module, and only those."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
MAP_PAGE = ROOT / "docs" / "reference" / "README.md"
#: Modules a contributor never needs to find by the map.
UNMAPPED = {"__init__.py", "_version.py"}


def code_map(text: str) -> dict[str, set[str]]:
    """Top-level folder -> the names listed under it in the first fenced block after "## Code layout".

    A listed line is indented two spaces; its names come before the first double space
    (``  base.py scoring.py        the shared API`` names ``base.py`` and ``scoring.py``).
    """
    block = re.search(r"^## Code layout$.*?^```text\n(.*?)^```", text, re.DOTALL | re.MULTILINE)
    assert block, f"{MAP_PAGE} has no code map"
    out: dict[str, set[str]] = {}
    top = ""
    for line in block.group(1).splitlines():
        if line and not line.startswith(" "):
            top = line.split()[0]
            out[top] = set()
        elif line.startswith("  ") and not line.startswith("   "):
            out[top] |= set(line[2:].split("  ")[0].split())
    return out


def on_disk(folder: Path) -> set[str]:
    """The packages (``name/``) and modules directly in ``folder``, :data:`UNMAPPED` aside."""
    packages = {f"{p.name}/" for p in folder.iterdir() if (p / "__init__.py").is_file()}
    return packages | {p.name for p in folder.glob("*.py") if p.name not in UNMAPPED}


def test_code_map_reads_names_before_the_description():
    text = "## Code layout\n\n```text\npkg/    the package\n  a.py b/     two\n    more of b\n```\n"
    assert code_map(text) == {"pkg/": {"a.py", "b/"}}


@pytest.mark.parametrize("package", ["inpaintenv", "estimators"])
def test_code_map_matches_the_code(package):
    mapped = code_map(MAP_PAGE.read_text(encoding="utf-8"))[f"{package}/"]
    actual = on_disk(ROOT / package)
    assert not actual - mapped, f"{MAP_PAGE.relative_to(ROOT)} does not list {sorted(actual - mapped)} under {package}/"
    gone = {name for name in mapped if not (ROOT / package / name.rstrip("/")).exists()}
    assert not gone, f"{MAP_PAGE.relative_to(ROOT)} lists {sorted(gone)} under {package}/, which do not exist"


def named_below(text: str) -> dict[tuple[str, str], set[str]]:
    """(top folder, entry) -> the module names (``x.py``) its description mentions.

    An entry is a line indented two spaces (``  learned/ ...``); the lines indented deeper
    below it continue its description.
    """
    block = re.search(r"^## Code layout$.*?^```text\n(.*?)^```", text, re.DOTALL | re.MULTILINE)
    assert block, f"{MAP_PAGE} has no code map"
    out: dict[tuple[str, str], set[str]] = {}
    top = entry = ""
    for line in block.group(1).splitlines():
        if line and not line.startswith(" "):
            top, entry = line.split()[0], ""
            continue
        if line.startswith("  ") and not line.startswith("   "):
            entry = line[2:].split()[0]
        out.setdefault((top, entry), set()).update(re.findall(r"(?<![\w/.-])([A-Za-z_]\w*\.py)\b", line))
    return out


def test_named_below_reads_each_entrys_modules():
    text = "## Code layout\n\n```text\npkg/    the package\n  sub/    its part: a.py, b.py\n        and c.py\n```\n"
    assert named_below(text) == {("pkg/", "sub/"): {"a.py", "b.py", "c.py"}}


@pytest.mark.parametrize("package", ["inpaintenv", "estimators"])
def test_every_module_the_map_names_is_where_it_says(package):
    # Below the top level too: a module named in a package's description is in that package.
    named = named_below(MAP_PAGE.read_text(encoding="utf-8"))
    wrong = []
    for (top, entry), modules in named.items():
        if top != f"{package}/":
            continue
        where = ROOT / package / entry.rstrip("/") if entry.endswith("/") else ROOT / package
        wrong += [f"{entry or top}: {m}" for m in sorted(modules) if not any(where.rglob(m))]
    assert not wrong, f"{MAP_PAGE.relative_to(ROOT)} names modules that are not where it puts them: {wrong}"
