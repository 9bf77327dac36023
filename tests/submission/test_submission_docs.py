"""docs/submissions.md shows the example method that the round-trip tests run, word for word."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def test_the_documented_script_is_the_tested_one():
    page = (ROOT / "docs" / "submissions.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", page, flags=re.DOTALL)
    script = (ROOT / "docs" / "examples" / "fill_holes.py").read_text()
    assert script in blocks


def test_readme_links_the_page():
    assert "(docs/submissions.md)" in (ROOT / "README.md").read_text()
