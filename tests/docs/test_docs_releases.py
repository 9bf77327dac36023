"""The docs name releases that exist (or existed: history), never offer a removed release as
loadable, say which release each registered name loads, and speak to users, not to the issue
tracker."""

from __future__ import annotations

import inspect
import re
from pathlib import Path

import pytest

from inpaintenv.methods.registry import (
    PRETRAINED_RELEASES,
    REMOVED_RELEASES,
    available_aliases,
    get_spec,
    resolve_class,
)

ROOT = Path(__file__).resolve().parents[2]
DOCS = ["README.md", "CHANGELOG.md", *sorted(str(p.relative_to(ROOT)) for p in (ROOT / "docs").rglob("*.md"))]
#: A release name as the docs write it: kitti-<family>-v<N>.
RELEASE = re.compile(r"\bkitti-[a-z]+-v\d+\b")
#: "`blend-pretrained` (`kitti-rect-v4`)": a registered name and, in brackets, what it loads.
PAIRED = re.compile(r"`(?P<name>[a-z][\w-]*)`(?: \(alias `[\w-]+`\))?,? \(`(?P<release>kitti-[a-z]+-v\d+)`\)")
#: A removed release offered as loadable: a method name, a loader's argument, a ``--name``.
LOADABLE = re.compile(r"(?:-m |--learned |--name |pretrained\(\"|load_release\(\"|make_method\(\")"
                      r"(?P<release>kitti-[a-z]+-v\d+)")
ISSUE = re.compile(r"\bissues? ?#?\d+", re.IGNORECASE)


def text(name: str) -> str:
    return (ROOT / name).read_text()


def release_loaded_by(name: str) -> str | None:
    """The shipped release that the registered ``name`` loads (its factory's ``name``), or None."""
    spec = get_spec(name)
    if "name" in spec.kwargs:
        return spec.kwargs["name"]
    factory = resolve_class(name)
    param = inspect.signature(factory).parameters.get("name") if callable(factory) else None
    return None if param is None or param.default is inspect.Parameter.empty else param.default


@pytest.mark.parametrize("name", DOCS)
def test_release_names_in_the_docs_are_registered(name):
    unknown = sorted(set(RELEASE.findall(text(name))) - set(PRETRAINED_RELEASES) - set(REMOVED_RELEASES))
    assert not unknown, f"{name} names releases the registry does not have: {unknown} (it has {PRETRAINED_RELEASES})"


@pytest.mark.parametrize("name", [d for d in DOCS if d != "CHANGELOG.md"])
def test_removed_releases_are_not_offered_as_loadable(name):
    """A release that left the package is history: no command or call in the docs loads it."""
    offered = sorted({m["release"] for m in LOADABLE.finditer(text(name))} & set(REMOVED_RELEASES))
    assert not offered, f"{name} loads releases that are no longer shipped: {offered} (shipped: {PRETRAINED_RELEASES})"


def test_docs_say_which_release_each_name_loads():
    pytest.importorskip("torch")
    wrong = []
    for name in DOCS:
        for m in PAIRED.finditer(text(name)):
            method = available_aliases().get(m["name"], m["name"])
            if m["name"] in PRETRAINED_RELEASES or method in PRETRAINED_RELEASES:
                continue
            try:
                loaded = release_loaded_by(method)
            except KeyError:
                continue  # not a registered name (e.g. a preset in backticks)
            if loaded is not None and loaded != m["release"]:
                wrong.append(f"{name}: `{m['name']}` (`{m['release']}`), but {m['name']} loads {loaded}")
    assert not wrong, "\n".join(wrong)


def test_lists_of_every_shipped_release_are_complete():
    # docs/evaluate.md listed "each shipped release by its name" without kitti-rect-v4.
    incomplete = []
    for name in DOCS:
        for para in re.split(r"\n\s*\n", text(name)):
            if re.search(r"(each|every|all) shipped releases?\b", para, re.IGNORECASE) and len(
                set(RELEASE.findall(para))
            ) >= 2:
                missing = sorted(set(PRETRAINED_RELEASES) - set(RELEASE.findall(para)))
                if missing:
                    incomplete.append(f"{name}: a list of every shipped release lacks {missing}")
    assert not incomplete, "\n".join(incomplete)


@pytest.mark.parametrize("name", DOCS)
def test_user_docs_do_not_cite_internal_issue_numbers(name):
    hits = [f"{name}:{text(name)[: m.start()].count(chr(10)) + 1}: {m.group()}" for m in ISSUE.finditer(text(name))]
    assert not hits, "say what the issue said instead of its number:\n" + "\n".join(hits)


#: Code, tests and scripts: they say what a thing does and why, never which tracker item asked for it
#: (history goes to CHANGELOG.md). This file is left out: it holds sample text for the pattern.
CODE = sorted(str(p.relative_to(ROOT)) for folder in ("inpaintenv", "estimators", "tests", "perf", "experiments")
              for p in (ROOT / folder).rglob("*") if p.suffix in (".py", ".sh") and p.name != Path(__file__).name)
#: A tracker reference in code: an issue number, or an item number of one.
TRACKER = re.compile(r"\bissues? ?#?\d+|\bitems? \d+(?![\w-])", re.IGNORECASE)


def test_code_and_tests_do_not_cite_tracker_items():
    hits = [f"{name}:{text(name)[: m.start()].count(chr(10)) + 1}: {m.group()}"
            for name in CODE for m in TRACKER.finditer(text(name))]
    assert not hits, "say what the item asked for instead of its number:\n" + "\n".join(hits)


def test_the_checks_catch_stale_names():
    assert PAIRED.search("the default, `blend-pretrained` (`kitti-rect-v3`), and")["release"] == "kitti-rect-v3"
    assert PAIRED.search("`blend-pretrained` (alias `unet-pretrained`) (`kitti-rect-v3`)") is not None
    assert LOADABLE.search('-m kitti-rect-v4 -m scanline')["release"] == "kitti-rect-v4"
    assert LOADABLE.search('BlendInpainter.pretrained("kitti-rect-v4")') and not LOADABLE.search("kitti-rect-v4's recipe")
    assert ISSUE.search("the natural next step (issue 8).") and ISSUE.search("see issues #12")
    assert TRACKER.search("(issue 43, item 5)") and TRACKER.search("# Item 13: a traceback")
    assert not TRACKER.search("the items 2-D array") and not TRACKER.search("issues/ tracker")
    assert not ISSUE.search("issues/ tracker") and RELEASE.findall("kitti-rect-v9 and kitti-mixed-v1") == [
        "kitti-rect-v9", "kitti-mixed-v1"]
