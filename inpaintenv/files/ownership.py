"""Which files of a run folder inpaintenv wrote, so that a run overwrites and deletes only those.

``inpaintenv benchmark``, ``score``, ``evaluate --out`` and ``train --out`` write into a
folder the user names. Each file they write is first recorded in the folder's :data:`LEDGER`
(``inpaintenv-files.json``, relative paths); a run replaces or deletes a file only if it
is recorded there. So:

* a folder that is neither empty nor a run folder of inpaintenv (it has no ledger, and no
  ``run.json`` or ``results.json`` of a run without a ledger) is refused with
  one line naming the folder and one of its files (:class:`ForeignFolderError`);
* in a run folder, a file at a path a run writes (``results.md``, ``rows/*.jsonl``,
  ``figures/frame_*.png``, ...; for ``train``: ``loss.png``, ``training_log.json``,
  ``model/config.json``, ...) that the ledger does not list -- e.g. one the user put
  there -- is refused the same way, before anything is scored;
* other files of a run folder (notes, a README) are never touched.

Empty folders count as empty (a run may leave an empty ``rows/``), and so do the lock
file (:data:`~.lock.LOCK_FILE`) and temporary files of interrupted atomic writes.
"""

from __future__ import annotations

import fnmatch
import json
import os
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

from .jsonio import loads_json, read_json
from .limits import MAX_JSON_BYTES
from .reading import read_bytes
from .writing import TEMP_PREFIX, write_text_atomic
from .lock import LOCK_FILE, holds_lock
from ..exceptions import ForeignFolderError, InpaintenvError

__all__ = [
    "BENCHMARK", "LEDGER", "RUN_FILES", "TRAIN", "TRAIN_FILES", "FolderKind", "ForeignFolderError", "adopt",
    "check_folder", "claim", "owns", "remove", "run_root",
]

#: The record of the files inpaintenv wrote in a run folder (relative POSIX paths).
LEDGER = "inpaintenv-files.json"

#: Paths (glob patterns, relative to the run folder) that benchmark, score and
#: ``evaluate --out`` write: one of them not in the ledger is a foreign file.
RUN_FILES: tuple[str, ...] = (
    "run.json", "results.json", "results.csv", "results.md", "table.csv", "table.md", "by_drive.csv",
    "partial-rows.jsonl", "rows/*.jsonl", "figures/*.png", "figures/figures.json", "figures/*/*.png",
    "figures/*/figures.json", "report.html",
)

#: Paths that ``inpaintenv train`` writes in its ``--out`` (its checkpoints are keyed
#: folders of their own under ``checkpoints/``).
TRAIN_FILES: tuple[str, ...] = (
    "train_args.json", "training_log.json", "loss.png", "model/config.json", "model/model.safetensors",
)


@dataclass(frozen=True)
class FolderKind:
    """What a command writes in its folder: the paths (glob patterns) and how to recognise
    a folder of its own that has no ledger."""

    #: Paths, relative to the folder, that the command writes.
    files: tuple[str, ...]
    #: Whether a folder without a ledger is one this command writes (its run files are there).
    legacy: Callable[[Path], bool]


def _regular(path: Path) -> bool:
    return path.is_file() and not path.is_symlink()


def _legacy_run(out: Path) -> bool:
    """A run folder of inpaintenv without a ledger: its run.json, or a results.json of ours."""
    if _regular(out / "run.json"):
        return True
    try:
        doc = read_json(out / "results.json", "results", follow_links=False)
    except (InpaintenvError, OSError):
        return False
    return isinstance(doc, dict) and {"meta", "rows"} <= set(doc)


def _legacy_train(out: Path) -> bool:
    """A training folder of inpaintenv without a ledger: its train_args.json, or the
    checkpoints of a training (``checkpoints/*/state.json``) that recorded none."""
    try:
        doc = read_json(out / "train_args.json", "training arguments", follow_links=False)
    except (InpaintenvError, OSError):
        return any(_regular(p) for p in (out / "checkpoints").rglob("state.json"))
    return isinstance(doc, dict) and "preset" in doc


#: The run folders of ``benchmark``, ``score`` and ``evaluate --out``.
BENCHMARK = FolderKind(RUN_FILES, _legacy_run)
#: The ``--out`` of ``inpaintenv train``.
TRAIN = FolderKind(TRAIN_FILES, _legacy_train)


def _foreign(out: Path, rel: str, why: str) -> ForeignFolderError:
    return ForeignFolderError(
        f"--out {out} {why} ({out / rel}); inpaintenv replaces and deletes only files it wrote there: "
        "move that file away, or give an empty or new folder as --out"
    )


def _exempt(rel: str) -> bool:
    name = rel.rsplit("/", 1)[-1]
    # Temporaries of an interrupted write: today's prefix, and the ``.<name>.<random>.tmp`` of earlier versions.
    return rel in (LEDGER, LOCK_FILE) or name.startswith(TEMP_PREFIX) or (name.startswith(".") and ".tmp" in name)


def _files(out: Path) -> Iterator[str]:
    """Relative paths of the files under ``out``, lazily (a huge folder stops at the first)."""
    for folder, dirs, files in os.walk(out):
        dirs.sort()
        for name in sorted(files):
            yield Path(folder, name).relative_to(out).as_posix()


def _run_paths(out: Path, kind: FolderKind) -> Iterator[str]:
    """Files (links, FIFOs, anything but a folder) under ``out`` at one of ``kind``'s paths."""
    for pattern in kind.files:
        for path in sorted(out.glob(pattern)):
            if path.is_symlink() or not path.is_dir():
                yield path.relative_to(out).as_posix()


def _read(out: Path) -> set[str] | None:
    path = out / LEDGER
    if not os.path.lexists(path):
        return None
    try:
        # A file of the folder the run owns: a link, FIFO, huge or deeply nested ledger is refused at once.
        doc = loads_json(read_bytes(path, "the list", limit=MAX_JSON_BYTES, follow_links=False), "it")
        files = doc["files"]
        if not isinstance(files, list) or not all(isinstance(f, str) for f in files):
            raise TypeError
    except (InpaintenvError, OSError, KeyError, TypeError) as exc:
        why = f" ({exc})" if isinstance(exc, (InpaintenvError, OSError)) else ""
        raise ForeignFolderError(
            f"cannot read {path}, the list of the files inpaintenv wrote in {out}{why}; delete that folder's run "
            "files and the list, or give another --out"
        ) from None
    return set(files)


def _write(out: Path, files: Iterable[str]) -> None:
    write_text_atomic(out / LEDGER, json.dumps({"written_by": "inpaintenv", "files": sorted(set(files))}, indent=1))


def check_folder(out: str | os.PathLike, kind: FolderKind = BENCHMARK) -> None:
    """Refuse ``out`` unless it is missing, empty, or a folder of inpaintenv without foreign files at ``kind``'s paths.

    Reads only; see the module docstring for the rules. ``kind``: :data:`BENCHMARK`
    (default) or :data:`TRAIN`.

    Raises
    ------
    ForeignFolderError
        Naming the folder and one file a run would overwrite or that marks the folder as
        someone else's.
    NotADirectoryError
        If ``out`` is a file.
    """
    out = Path(out)
    if not out.exists():
        return
    if not out.is_dir():
        raise NotADirectoryError(f"--out {out} is a file; the run folder must be a folder")
    owned = _read(out)
    if owned is None:
        if kind.legacy(out):
            return  # every file at a run path was written by that run
        first = next((rel for rel in _files(out) if not _exempt(rel)), None)
        if first is not None:
            raise _foreign(out, first, "is neither empty nor a run folder of inpaintenv")
        return
    stray = next((rel for rel in _run_paths(out, kind) if rel not in owned and not _exempt(rel)), None)
    if stray is not None:
        raise _foreign(out, stray, "holds a file that no inpaintenv run wrote where a run writes its results")


def adopt(out: str | os.PathLike, kind: FolderKind = BENCHMARK) -> None:
    """Check ``out`` (:func:`check_folder`), create it, and make sure it has a ledger.

    A run folder without a ledger is adopted: the files at ``kind``'s paths in
    it are recorded as its own. Inside the folder's run lock the folder is not checked again:
    the command that took the lock checked it first.
    """
    out = Path(out)
    if not holds_lock(out):
        check_folder(out, kind)
    out.mkdir(parents=True, exist_ok=True)
    if _read(out) is None:
        _write(out, list(_run_paths(out, kind)) if kind.legacy(out) else [])


def claim(out: str | os.PathLike, *paths: str | os.PathLike, kind: FolderKind = BENCHMARK) -> None:
    """Record ``paths`` (relative to ``out``, or absolute paths under it) as written by inpaintenv,
    before they are written (``kind``: what writes the folder, see :func:`check_folder`).

    Raises
    ------
    ForeignFolderError
        If one of them exists and is not recorded (someone else's file).
    """
    out = Path(out)
    adopt(out, kind)
    owned = _read(out) or set()
    new = []
    for path in paths:
        rel = _relative(out, path)
        if rel in owned:
            continue
        if (out / rel).exists() or (out / rel).is_symlink():
            raise _foreign(out, rel, "holds a file that no inpaintenv run wrote")
        new.append(rel)
    if new:
        _write(out, owned | set(new))


def owns(out: str | os.PathLike, path: str | os.PathLike) -> bool:
    """Whether ``path`` (relative to ``out``, or an absolute path under it) is recorded as written by inpaintenv."""
    owned = _read(Path(out))
    return owned is not None and _relative(Path(out), path) in owned


def remove(out: str | os.PathLike, path: str | os.PathLike) -> bool:
    """Delete ``path`` if inpaintenv recorded writing it (and forget it); return whether it did.

    A file the ledger does not list is left where it is.
    """
    out = Path(out)
    rel = _relative(out, path)
    owned = _read(out)
    if owned is None or rel not in owned:
        return False
    (out / rel).unlink(missing_ok=True)
    _write(out, owned - {rel})
    return True


def _relative(out: Path, path: str | os.PathLike) -> str:
    p = Path(path)
    if p.is_absolute():
        return p.resolve().relative_to(out.resolve()).as_posix()
    return p.as_posix()


def run_root(folder: str | os.PathLike) -> Path:
    """The run folder whose ledger covers files in ``folder``: ``folder`` itself, or its parent
    when the parent is a run folder (``figures/`` of a benchmark run), or its grandparent
    (``figures/<task>/``)."""
    folder = Path(folder)
    if os.path.lexists(folder / LEDGER):
        return folder
    for above in (folder.parent, folder.parent.parent):
        if os.path.lexists(above / LEDGER):
            return above
    return folder
