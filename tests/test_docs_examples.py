"""The Python examples in README.md and docs/*.md run as written."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def python_blocks(name: str) -> str:
    text = (ROOT / name).read_text()
    return "\n".join(re.findall(r"```python\n(.*?)```", text, flags=re.DOTALL))


@pytest.mark.parametrize("name", ["README.md", "docs/env.md", "docs/evaluate.md", "docs/benchmark.md"])
def test_doc_examples_run(name, tmp_path, monkeypatch, capsys):
    code = python_blocks(name)
    assert code.strip(), f"no python examples in {name}"
    monkeypatch.chdir(tmp_path)
    # Running the documented code is the point of this test.
    exec(compile(code.replace("/tmp/", f"{tmp_path}/"), name, "exec"), {"__name__": "__doc_example__"})  # noqa: S102
    assert capsys.readouterr().out  # the examples print their results
