"""The Markdown documentation stays short enough to read: README.md and every page under docs/.

* all of them together at most :data:`TOTAL` bytes, and no page over :data:`PAGE` bytes;
* each page says what it is for on its first screen: its first block after the title is a
  prose paragraph (not a table, a code block, a list or a picture) and starts within the first
  :data:`FIRST_SCREEN` lines.

CHANGELOG.md is history, not documentation a user reads to get something done, and is not
counted. A page that outgrows these limits moves its history to CHANGELOG.md, keeps one home
for an explanation repeated elsewhere (a link instead), or keeps a final table with its command
instead of the intermediate ones.
"""

from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
#: Bytes of all pages together.
TOTAL = 200_000
#: Bytes of any one page.
PAGE = 12_000
#: Lines within which a page's first paragraph (what it is for) must start.
FIRST_SCREEN = 15
#: First characters of a line that starts something other than a prose paragraph.
NOT_PROSE = ("#", "```", "|", "<!--", "![", "- ", "* ", "1. ", ">")


def name(page: Path) -> str:
    return str(page.relative_to(ROOT))


def first_paragraph_line(text: str) -> int | None:
    """1-based line of the first non-heading block when it is prose, else None."""
    for number, line in enumerate(text.splitlines(), start=1):
        stripped = line.strip()
        if not stripped or stripped.startswith("#"):
            continue
        return None if stripped.startswith(NOT_PROSE) else number
    return None


def test_the_docs_together_stay_under_the_total():
    sizes = {name(p): len(p.read_bytes()) for p in PAGES}
    total = sum(sizes.values())
    largest = ", ".join(f"{n} {s:,}" for n, s in sorted(sizes.items(), key=lambda kv: -kv[1])[:8])
    assert total <= TOTAL, (f"README.md + docs/**/*.md hold {total:,} bytes, over {TOTAL:,}: cut history, "
                            f"repeated explanations or intermediate tables (largest pages: {largest})")


def test_no_page_is_over_the_page_limit():
    over = [f"{name(p)} {len(p.read_bytes()):,} bytes" for p in PAGES if len(p.read_bytes()) > PAGE]
    assert not over, f"pages over {PAGE:,} bytes: " + "; ".join(over)


def test_every_page_says_first_what_it_is_for():
    late = []
    for page in PAGES:
        line = first_paragraph_line(page.read_text(encoding="utf-8"))
        if line is None or line > FIRST_SCREEN:
            late.append(f"{name(page)} (first paragraph at line {line})" if line else
                        f"{name(page)} (its first block after the title is not a paragraph)")
    assert not late, (f"each page's first block after its title must be a paragraph saying what the page is "
                      f"for, within {FIRST_SCREEN} lines: " + "; ".join(late))


@pytest.mark.parametrize("text, line", [
    ("# T\n\nWhat this is for.\n", 3),
    ("# T\n\n| a | b |\n", None),
    ("# T\n\n```bash\nx\n```\n\nLate prose.\n", None),
    ("# T\n## Sub\n" + "\n" * 20 + "Far down.\n", 23),
])
def test_the_first_paragraph_check_reads_the_first_block(text, line):
    assert first_paragraph_line(text) == line
