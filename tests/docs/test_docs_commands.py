"""The shell commands in README.md and docs/**/*.md name things that exist and run in order.

Every fenced ```bash / ```sh / ```console block is read line by line (backslash
continuations joined, ``&&`` / ``;`` / ``|`` split, ``NAME=value`` lines of the block
substituted into later ones). For each command:

* ``inpaintenv SUB ...``: parsed by the real argparse parser in-process (no data run),
  so a renamed flag or subcommand fails here;
* ``python path.py ...``: the script exists in the repository and every ``--flag`` used is
  declared by an ``add_argument`` call in it (read from its source, not run);
* ``python -m module`` / ``torchrun ... -m module``: the module can be found;
* no path leaves the repository (``../shared/...``): docs say ``<KITTI root>``.

And the commands run in the order the docs give them: two ``benchmark`` (``train``)
commands anywhere in the docs that share an ``--out`` are the same run, a
``--checkpoint`` comes from an earlier ``train`` of its page, and README's commands run
for real, in order, on the real slice.

Placeholders such as ``<KITTI root>`` or ``<held-out drive>`` stand for one argument.
Unlabelled fences whose first line is a command must be labelled ``bash`` so this test sees them.
"""

from __future__ import annotations

import argparse
import ast
import contextlib
import functools
import importlib.util
import io
import re
import shlex
import sys
from pathlib import Path

import pytest

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    tomllib = pytest.importorskip("tomli")

from inpaintenv.cli import build_parser

ROOT = Path(__file__).resolve().parents[2]
DOCS = ["README.md", *sorted(str(p.relative_to(ROOT)) for p in (ROOT / "docs").rglob("*.md"))]
SHELL = ("bash", "sh", "console", "shell")
FENCE = re.compile(r"^( *)```(\w*)[^\n]*\n(.*?)^\1```", flags=re.DOTALL | re.MULTILINE)
PLACEHOLDER = re.compile(r"<[A-Za-z][^<>\n]*>")
PROGRAMS = ("python", "inpaintenv", "torchrun", "pip")
KEYWORDS = ("do", "then", "else", "time", "exec")


def blocks(name: str, languages: tuple[str, ...]) -> list[tuple[int, str]]:
    """(line number, body) of the fenced blocks of ``name`` in one of ``languages``."""
    text = (ROOT / name).read_text()
    return [(text[: m.start()].count("\n") + 1, m.group(3)) for m in FENCE.finditer(text) if m.group(2) in languages]


def commands(body: str) -> list[list[str]]:
    """The commands of a shell block as argument lists (see the module docstring)."""
    out: list[list[str]] = []
    env: dict[str, str] = {}
    text = re.sub(r"\\\n", " ", body)
    for line in text.splitlines():
        line = line.strip().removeprefix("$ ")
        line = PLACEHOLDER.sub("PLACEHOLDER", line)
        if not line or line.startswith("#"):
            continue
        for name, value in env.items():
            line = re.sub(rf"\$\{{?{name}\}}?\b", value, line)
        for part in re.split(r"&&|\|\||;|\|", line):
            try:
                words = shlex.split(part, comments=True)
            except ValueError as e:  # unbalanced quotes
                raise AssertionError(f"cannot parse shell line {line!r}: {e}") from None
            assign = [w for w in words if re.fullmatch(r"[A-Za-z_]\w*=.*", w)]
            if assign and len(assign) == len(words):  # NAME=value lines set variables
                env.update(w.split("=", 1) for w in assign)
                continue
            # `VAR=x cmd` (an environment prefix) and loop/condition keywords precede the program.
            while words and (re.fullmatch(r"[A-Za-z_]\w*=.*", words[0]) or words[0] in KEYWORDS):
                words.pop(0)
            if words:
                out.append(words)
    return out


def doc_commands() -> list[tuple[str, list[str]]]:
    return [(f"{name}:{line}", cmd) for name in DOCS for line, body in blocks(name, SHELL) for cmd in commands(body)]


def script_flags(path: Path) -> set[str]:
    """Option strings (``--x``, ``-x``) declared by ``add_argument`` calls in a script."""
    flags = {"-h", "--help"}
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Call) and getattr(node.func, "attr", None) == "add_argument":
            flags |= {a.value for a in node.args if isinstance(a, ast.Constant) and str(a.value).startswith("-")}
    return flags


def used_flags(args: list[str]) -> list[str]:
    return [a.split("=", 1)[0] for a in args if a.startswith("-") and a != "-" and not re.fullmatch(r"-[\d.]+", a)]


@functools.cache
def parser() -> argparse.ArgumentParser:
    return build_parser()


def check_inpaintenv(args: list[str]) -> str | None:
    """None if ``inpaintenv ARGS`` parses, else argparse's message."""
    err = io.StringIO()
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            parser().parse_args(args)
    except SystemExit as e:
        if e.code:
            return err.getvalue().strip().splitlines()[-1]
    return None


def check_module(name: str) -> str | None:
    try:
        found = importlib.util.find_spec(name)
    except ModuleNotFoundError:
        found = None
    return None if found else f"module {name} not found"


def check_python(args: list[str]) -> str | None:
    """Check ``python ARGS``: a script of the repository with its declared flags, or ``-m module``."""
    if args[:1] == ["-m"]:
        return check_module(args[1])
    if args[:1] == ["-c"] or not args:
        return None
    script = ROOT / args[0].removeprefix("PLACEHOLDER/")  # <this repository>/perf/x.py
    if not script.is_file():
        return f"script {args[0]} does not exist in the repository"
    unknown = sorted(set(used_flags(args[1:])) - script_flags(script))
    return f"{args[0]} declares no option {unknown}" if unknown else None


def check_pip(args: list[str]) -> str | None:
    """``pip install -e ".[extra]"``: the extras exist in pyproject.toml."""
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"].get("optional-dependencies", {})
    for arg in args:
        if m := re.fullmatch(r"\.\[([\w,-]+)\]", arg):
            unknown = sorted(set(m[1].split(",")) - set(extras))
            if unknown:
                return f"pyproject.toml has no extra {unknown} (it has {sorted(extras)})"
    return None


def check(cmd: list[str]) -> str | None:
    """None if the command is right, else what is wrong with it."""
    outside = [w for w in cmd if re.search(r"(^|[=/])\.\./", w) or w.startswith("/work/")]
    if outside:
        return f"path outside the repository {outside}; docs say <KITTI root> for the data"
    program, args = cmd[0], cmd[1:]
    if program == "inpaintenv":
        return check_inpaintenv(args)
    if program in ("python", "python3"):
        return check_python(args)
    if program == "pip":
        return check_pip(args)
    if program == "torchrun":
        return check_module(args[args.index("-m") + 1]) if "-m" in args else check_python([a for a in args if not a.startswith("-")][-1:])
    return None


def test_commands_are_collected():
    cmds = [c for _, c in doc_commands()]
    assert sum(c[0] == "inpaintenv" for c in cmds) >= 5
    assert any(c[0] == "python" and c[1].startswith("perf/") for c in cmds)
    assert commands('K=<KITTI root>\ninpaintenv info --kitti-root $K \\\n  --split val && python -m pytest -q\n') == [
        ["inpaintenv", "info", "--kitti-root", "PLACEHOLDER", "--split", "val"], ["python", "-m", "pytest", "-q"]]


def test_the_checks_catch_wrong_commands(tmp_path):
    assert check(["inpaintenv", "benchmark", "--no-such-flag"]) is not None
    assert check(["inpaintenv", "no-such-command"]) is not None
    assert check(["inpaintenv", "benchmark", "--kitti-root", "PLACEHOLDER", "-m", "harmonic"]) is None
    assert "does not exist" in check(["python", "perf/no_such_script.py"])
    assert "declares no option" in check(["python", "perf/bench_masks.py", "--no-such-flag"])
    assert check(["python", "perf/bench_masks.py", "--stats", "10"]) is None
    assert "outside the repository" in check(["inpaintenv", "info", "--kitti-root", "../shared/kitti"])
    assert check(["python", "-m", "no_such_module_here"]) is not None
    assert check(["python", "PLACEHOLDER/perf/bench_masks.py", "--stats", "10"]) is None
    assert check(["pip", "install", "-e", ".[test]"]) is None
    assert "no extra" in check(["pip", "install", "-e", ".[no-such-extra]"])
    assert commands("for p in a b; do inpaintenv train --preset $p; done") == [
        ["for", "p", "in", "a", "b"], ["inpaintenv", "train", "--preset", "$p"], ["done"]]


@pytest.mark.parametrize("where, cmd", doc_commands(), ids=lambda v: v if isinstance(v, str) else None)
def test_doc_command_names_what_exists(where, cmd):
    problem = check(cmd)
    assert problem is None, f"{where}: {shlex.join(cmd)}: {problem}"


@pytest.mark.parametrize("name", DOCS)
def test_command_blocks_are_labelled(name):
    # An unlabelled fence that starts with a command would escape the checks above.
    unlabelled = [line for line, body in blocks(name, ("",)) if body.strip() and (
        body.split()[0] in PROGRAMS or re.fullmatch(r"[A-Za-z_]\w*=.*", body.split()[0]))]
    assert not unlabelled, f"{name}: label the command blocks at lines {unlabelled} as ```bash"


@pytest.mark.parametrize("name", DOCS)
def test_docs_name_no_path_outside_the_repository(name):
    text = (ROOT / name).read_text()
    assert "../shared" not in text and "/work/" not in text, f"{name}: say <KITTI root> (or INPAINTENV_KITTI_ROOT)"




#: Options of ``inpaintenv benchmark`` that fingerprint a run (data, frames, protocols, seeds):
#: a second command into the same --out with other values stops with "holds results of a
#: different run". Methods may differ (they add rows).
RUN_OPTIONS = ("kitti_root", "synthetic", "split", "camera", "kind", "drives", "exclude_drives", "n_frames",
               "frame_shape", "data_seed", "holdout", "protocol", "seed")
#: Options of ``inpaintenv train`` that decide what is trained (another value starts over).
TRAIN_OPTIONS = ("preset", "max_steps", "seed", "device", "kitti_root", "synthetic", "split", "camera", "kind",
                 "drives", "exclude_drives", "n_frames", "frame_shape", "data_seed")


def run_key(cmd: list[str]) -> tuple[str, str, tuple] | None:
    """(subcommand, --out folder, the options that must agree there) of a benchmark or train command."""
    if cmd[:1] != ["inpaintenv"] or len(cmd) < 2 or cmd[1] not in ("benchmark", "train"):
        return None
    args = parser().parse_args(cmd[1:])
    if args.command == "train" and args.list:
        return None
    names = RUN_OPTIONS if args.command == "benchmark" else TRAIN_OPTIONS
    values = []
    for name in names:
        value = getattr(args, name)
        values.append((name, tuple(value) if isinstance(value, list) else value))
    return args.command, str(Path(args.out)).rstrip("/"), tuple(values)


def test_documented_runs_do_not_collide_in_one_folder():
    # README's "how good" command had no --out: after README's first KITTI command it
    # stopped with "benchmark-results holds results of a different run". Every documented
    # benchmark (train) command that shares an --out with another must be the same run,
    # across README and every page, so that they run in any order the docs give them.
    first: dict[tuple[str, str], tuple[str, tuple]] = {}
    clashes = []
    for where, cmd in doc_commands():
        key = run_key(cmd)
        if key is None or "$" in key[1]:  # a loop variable: one folder per value
            continue
        command, out, values = key
        seen = first.setdefault((command, out), (where, values))
        if seen[1] != values:
            differ = sorted(n for (n, a), (_, b) in zip(seen[1], values) if a != b)
            clashes.append(f"{where}: {command} --out {out} is also used by {seen[0]} for another run ({differ})")
    assert not clashes, "\n".join(clashes)


def test_the_collision_check_catches_a_clash():
    a = run_key(["inpaintenv", "benchmark", "--kitti-root", "PLACEHOLDER", "--split", "val"])
    b = run_key(["inpaintenv", "benchmark", "--kitti-root", "PLACEHOLDER", "--split", "val", "--seed", "1"])
    c = run_key(["inpaintenv", "benchmark", "--kitti-root", "PLACEHOLDER", "--split", "val", "-m", "harmonic"])
    assert a[:2] == b[:2] == ("benchmark", "benchmark-results") and a[2] != b[2]
    assert a == c  # other methods add rows to the same run


def test_checkpoints_come_from_an_earlier_command_of_the_page():
    # A page that scores `--checkpoint NAME=runs/x/model` must train into runs/x before it.
    import fnmatch

    missing = []
    for name in DOCS:
        trained: list[str] = []
        for line, body in blocks(name, SHELL):
            for cmd in commands(body):
                if cmd[:2] == ["inpaintenv", "train"] and "--list" not in cmd:
                    out = parser().parse_args(cmd[1:]).out
                    trained.append(re.sub(r"\$\{?\w+\}?", "*", out.rstrip("/")))
                elif cmd[:2] in (["inpaintenv", "benchmark"], ["inpaintenv", "evaluate"]):
                    for spec in parser().parse_args(cmd[1:]).checkpoint or []:
                        path = spec.split("=", 1)[-1].rstrip("/").removesuffix("/model")
                        if "PLACEHOLDER" not in path and not any(fnmatch.fnmatch(path, t) for t in trained):
                            missing.append(f"{name}:{line}: --checkpoint {spec} is trained by no earlier command")
    assert not missing, "\n".join(missing)


def _without_options(args: list[str], names: tuple[str, ...]) -> list[str]:
    """``args`` less every ``NAME VALUE`` pair of the options ``names``."""
    kept, skip = [], False
    for a in args:
        if skip:
            skip = False
        elif a in names:
            skip = True
        else:
            kept.append(a)
    return kept


@pytest.mark.kitti
@pytest.mark.slow
def test_readme_commands_run_in_the_order_given(kitti_root, tmp_path, monkeypatch):
    # Run, in one folder and in README order, every `inpaintenv` command of README.md, each
    # with one fast method instead of the suite (methods do not change which run a folder
    # holds, so a collision of two commands still fails here) and no figures.
    from inpaintenv.cli import main

    monkeypatch.chdir(tmp_path)
    ran = []
    for line, body in blocks("README.md", SHELL):
        for cmd in commands(body):
            if cmd[0] != "inpaintenv":
                continue
            args = [str(kitti_root) if a == "PLACEHOLDER" else a for a in cmd[1:]]
            if args[0] == "benchmark":
                args = _without_options(args, ("-m", "--method", "--figure-frames"))
                args += ["-m", "scanline", "--figure-frames", "0", "--quiet"]
            assert main(args) == 0, f"README.md:{line}: {shlex.join(cmd)} failed (see its error above)"
            ran.append(args[0])
    assert ran.count("benchmark") >= 3
