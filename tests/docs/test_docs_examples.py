"""Every Python example in README.md and docs/**/*.md runs as written.

The ```python blocks of a page run in order in one namespace, like a notebook, from a
temporary working folder. A block may be marked by an HTML comment on the line before it:

* ``<!-- doc-example: kitti -->``: needs real KITTI. It runs with ``"<KITTI root>"``
  replaced by the real slice the tests use (``$INPAINTENV_KITTI_ROOT``), and is skipped
  (with that reason) when there is none; unmarked blocks must not depend on it.
* ``<!-- doc-example: skip (reason) -->``: never runs here; the reason is the rule a
  reader sees (e.g. it needs a cluster).

Every other block runs on the built-in data. Blocks that train use tiny settings.
"""

from __future__ import annotations

import re
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DOCS = ["README.md", *sorted(str(p.relative_to(ROOT)) for p in (ROOT / "docs").rglob("*.md"))]
BLOCK = re.compile(
    r"^(?:[ \t]*<!--\s*doc-example:\s*(?P<mark>.*?)\s*-->[ \t]*\n)?(?P<indent>[ \t]*)```python[^\n]*\n(?P<code>.*?)^(?P=indent)```",
    flags=re.DOTALL | re.MULTILINE,
)


def examples(name: str) -> list[tuple[int, str, str]]:
    """(line, mark, code) of every ```python block of ``name``; mark is "" when unmarked."""
    text = (ROOT / name).read_text()
    return [(text[: m.start("indent")].count("\n") + 1, (m["mark"] or "").strip(), textwrap.dedent(m["code"]))
            for m in BLOCK.finditer(text)]


PAGES = [name for name in DOCS if examples(name)]
#: Pages whose examples take more than a few seconds (training, a grid search, loky workers).
SLOW = {"docs/neural.md", "docs/estimators.md", "docs/benchmark.md"}


def test_every_page_with_python_is_run():
    # A page that gains its first example is picked up without editing this file.
    assert {"README.md", "docs/estimators.md", "docs/model_card.md", "docs/neural.md", "docs/data.md"} <= set(PAGES)
    for name in DOCS:
        for line, mark, _ in examples(name):
            assert mark in ("", "kitti") or mark.startswith("skip ("), f"{name}:{line}: unknown mark {mark!r}"


@pytest.mark.parametrize("name", [pytest.param(p, marks=pytest.mark.slow) if p in SLOW else p for p in PAGES])
def test_doc_examples_run(name, tmp_path, monkeypatch, capsys, request):
    try:  # the shared fixture finds the real slice, and skips when there is none
        kitti_root = request.getfixturevalue("kitti_root")
    except pytest.skip.Exception:
        kitti_root = None
    if kitti_root is not None:  # blocks relying on the variable (KittiDepth(root=None)) find it too
        monkeypatch.setenv("INPAINTENV_KITTI_ROOT", str(kitti_root))
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {"__name__": "__doc_example__"}
    needs_kitti = []
    for line, mark, code in examples(name):
        if mark.startswith("skip"):
            continue
        # Documented /tmp/ paths go to the test's folder; first, so a KITTI root that itself
        # lies under /tmp (a CI clone there) is not rewritten with them.
        code = code.replace("/tmp/", f"{tmp_path}/")
        if mark == "kitti":
            if kitti_root is None:
                needs_kitti.append(line)
                continue
            code = code.replace('"<KITTI root>"', repr(str(kitti_root)))
        # Running the documented code is the point of this test.
        exec(compile(code, f"{name}:{line}", "exec"), namespace)  # noqa: S102
    if needs_kitti:
        pytest.skip(f"{name}: blocks at lines {needs_kitti} need KITTI (INPAINTENV_KITTI_ROOT is unset); the others ran")
    capsys.readouterr()
