"""The jobs of a ``fill`` run: which input files there are and which files each becomes."""

from __future__ import annotations

import os
import stat
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from ..data.depth_files import DEPTH_SUFFIXES
from ..exceptions import InvalidInputError
from ..files import describe_kind
from ..progress import count

__all__ = ["FORMATS", "INTERVAL_SUFFIXES", "POINT_FORMATS", "SCAN_SUFFIX", "FillJob", "FillReport", "plan"]

#: Values of ``format``: the depth files written per input.
FORMATS = {"png": (".png",), "npy": (".npy",), "both": (".png", ".npy")}
#: Values of ``points``: the point files written per scan.
POINT_FORMATS = {None: (), "bin": (".bin",), "ply": (".ply",), "both": (".bin", ".ply")}
#: Suffix of a LiDAR scan input.
SCAN_SUFFIX = ".bin"
#: Suffixes (before the format's) of the interval files written beside each depth file.
INTERVAL_SUFFIXES = ("_low", "_high")
#: What the preview's name adds to the input's stem (``frame.png`` -> ``frame_preview.png``).
PREVIEW_SUFFIX = "_preview"


@dataclass(frozen=True)
class FillJob:
    """One input file and the files it becomes.

    Attributes
    ----------
    source : pathlib.Path
        The input file.
    rel : pathlib.Path
        Its path relative to the input it was found in (the file name for a file input).
    outputs : tuple of pathlib.Path
        The depth files, then (scans only) the point files.
    intervals : tuple of (pathlib.Path, pathlib.Path)
        With ``confidence``: per depth file, its ``_low`` and ``_high`` files.
    preview : pathlib.Path or None
        With ``preview``: the colour picture ``<name>_preview.png`` (:mod:`.preview`).
    """

    source: Path
    rel: Path
    outputs: tuple[Path, ...]
    intervals: tuple[tuple[Path, Path], ...] = ()
    preview: Path | None = None

    @property
    def all_outputs(self) -> tuple[Path, ...]:
        """Every file the job writes: depth, interval, point files and the preview."""
        return (*self.outputs, *(p for pair in self.intervals for p in pair),
                *((self.preview,) if self.preview is not None else ()))

    @property
    def out(self) -> Path:
        """The output folder the job writes into (each output is ``out / rel`` with its suffix)."""
        return self.outputs[0].parents[len(self.rel.parts) - 1]

    @property
    def is_scan(self) -> bool:
        """Whether the input is a LiDAR scan (``.bin``)."""
        return self.source.suffix.lower() == SCAN_SUFFIX


@dataclass
class FillReport:
    """What a :func:`~inpaintenv.filling.fill` run did: inputs written, skipped (outputs existed) and failed (with why).

    ``routes`` counts, for a method that fills each input kind its own way (``pretrained``),
    the inputs written per ``(kind, method that filled it)``, e.g. ``("scan", "harmonic-ipbasic")``;
    ``method`` is the run's method name.
    """

    written: list[Path] = field(default_factory=list)
    skipped: list[Path] = field(default_factory=list)
    failed: list[tuple[Path, str]] = field(default_factory=list)
    ignored: list[Path] = field(default_factory=list)
    routes: dict[tuple[str, str], int] = field(default_factory=dict)
    method: str = ""

    @property
    def ok(self) -> bool:
        """True when no input failed."""
        return not self.failed

    def summary(self) -> str:
        """``fill: 12 written, 3 skipped (outputs exist; overwrite to redo), 1 failed``, then what filled what
        (``; pretrained filled 12 as scans with harmonic-ipbasic``) for a method routed by input kind."""
        skipped = f"{len(self.skipped)} skipped" + (" (outputs exist; --overwrite to redo them)" if self.skipped else "")
        line = f"fill: {len(self.written)} written, {skipped}, {len(self.failed)} failed"
        if self.routes:  # which method filled which kind of input: a scan and a map are filled differently
            routes = ", ".join(f"{n} as {kind}s with {name}" for (kind, name), n in self.routes.items())
            line += f"; {self.method} filled {routes}"
        if self.ignored:
            line += (f"; {count(len(self.ignored), 'file')} of other kinds left alone (e.g. {self.ignored[0]}); "
                     f"read are {', '.join((*DEPTH_SUFFIXES, SCAN_SUFFIX))}")
        return line


def _walk(folder: Path) -> Iterator[Path]:
    """Files under ``folder``, sorted, hidden ones (``.name``, e.g. temporary files) left out."""
    for root, dirs, files in os.walk(folder):
        dirs[:] = sorted(d for d in dirs if not d.startswith("."))
        for name in sorted(files):
            if not name.startswith("."):
                yield Path(root) / name


def _is_under(path: Path, folder: Path) -> bool:
    return path == folder or folder in path.parents


def _interval_pair(path: Path) -> tuple[Path, Path]:
    """The ``_low`` and ``_high`` files beside the depth file ``path``."""
    return tuple(path.with_name(path.stem + s + path.suffix) for s in INTERVAL_SUFFIXES)  # type: ignore[return-value]


def _not_regular(path: Path) -> str | None:
    """Why ``path`` cannot be read as a file (a FIFO, a device, a broken link), or None for a regular file.

    Checked before anything opens it: opening a FIFO for reading waits for a writer forever.
    """
    try:
        mode = os.stat(path).st_mode
    except OSError as exc:
        return f"{path}: cannot be read ({exc.strerror or exc}{'; a broken link?' if path.is_symlink() else ''})"
    if stat.S_ISREG(mode):
        return None
    return f"{path} is {describe_kind(mode)}, not a regular file; not read"


def _found(given: Path, out: Path, out_abs: Path, masks: list[Path]) -> list[tuple[Path, Path]] | None:
    """The files of one INPUT with their relative paths; None if nothing is there."""
    if given.is_dir():
        if _is_under(out_abs, given.resolve()):
            raise InvalidInputError(f"--out {out} lies inside the input folder {given}; fill never writes into an "
                                    "input folder: give another --out")
        return [(p, p.relative_to(given)) for p in _walk(given)
                if not masks or not any(_is_under(p.resolve(), m) for m in masks)]
    if given.is_file() or os.path.lexists(given):  # a FIFO or device given by name: refused by its kind
        return [(given, Path(given.name))]
    return None


def plan(inputs: Sequence[str | os.PathLike], out: str | os.PathLike, *, format: str = "png",
         points: str | None = None, protect: Sequence[str | os.PathLike] = (), confidence: bool = False,
         preview: bool = False) -> tuple[
             list[FillJob], list[tuple[Path, str]], list[Path]]:
    """The jobs of a run: ``(jobs, missing inputs with why, ignored files)``.

    Parameters
    ----------
    inputs : sequence of path-like
        Files and folders (read recursively, hidden files left out).
    out : path-like
        The output folder.
    format : {"png", "npy", "both"}
        Depth files per input.
    points : {None, "bin", "ply", "both"}
        Point files per scan.
    protect : sequence of path-like
        Further files or folders never written into, whose files are not inputs (the mask
        or folder of masks, when it lies inside an input folder).
    confidence : bool
        Each depth file has its interval files beside it.
    preview : bool
        Each input also has a colour picture, ``<name>_preview.png`` (:mod:`.preview`).

    Returns
    -------
    tuple
        The jobs, the inputs that failed already with why, the files of other kinds left alone.

    Raises
    ------
    InvalidInputError
        If an output would be an input or lie in an input (or ``protect``) folder, ``out``
        is a file, or two inputs would write the same output (every such pair listed).
    """
    if format not in FORMATS:
        raise InvalidInputError(f"format must be one of {', '.join(FORMATS)}, got {format!r}")
    if points not in POINT_FORMATS:
        raise InvalidInputError(f"points must be None, 'bin', 'ply' or 'both', got {points!r}")
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise InvalidInputError(f"--out {out} is a file; give a folder")
    out_abs = out.resolve()
    given_all = [Path(p) for p in inputs]
    masks = [Path(p).resolve() for p in protect]
    folders = [g.resolve() for g in given_all if g.is_dir()] + masks
    files = {g.resolve() for g in given_all if g.is_file()}
    jobs, missing, ignored, by_output = [], [], [], {}
    collisions: list[tuple[Path, Path, Path, bool]] = []
    for given in given_all:
        found = _found(given, out, out_abs, masks)
        if found is None:
            missing.append((given, f"{given}: no such file or folder"))
            continue
        for path, rel in found:
            suffix = path.suffix.lower()
            if suffix not in (*DEPTH_SUFFIXES, SCAN_SUFFIX):
                if given.is_dir():
                    ignored.append(path)
                else:
                    missing.append((path, f"{path}: not a depth file or scan (read are "
                                          f"{', '.join((*DEPTH_SUFFIXES, SCAN_SUFFIX))})"))
                continue
            why = _not_regular(path)
            if why is not None:
                missing.append((path, why))
                continue
            extra = POINT_FORMATS[points] if suffix == SCAN_SUFFIX else ()
            outputs = tuple(out / rel.with_suffix(s) for s in (*FORMATS[format], *extra))
            intervals = tuple(_interval_pair(out / rel.with_suffix(s)) for s in FORMATS[format]) if confidence else ()
            shown = out / rel.with_name(rel.stem + PREVIEW_SUFFIX + ".png") if preview else None
            job = FillJob(path, rel, outputs, intervals, shown)
            for o in job.all_outputs:
                if o.resolve() in files or any(_is_under(o.resolve(), f) for f in folders):
                    raise InvalidInputError(f"{path} would be filled into {o}, an input or inside an input folder; "
                                            "fill never writes there: give another --out")
                if o.resolve() in by_output:
                    other, other_rel = by_output[o.resolve()]
                    collisions.append((other, path, o, other_rel == rel))
                by_output[o.resolve()] = (path, rel)
            jobs.append(job)
    if collisions:
        _refuse_collisions(collisions)
    return jobs, missing, ignored


def _refuse_collisions(collisions: list[tuple[Path, Path, Path, bool]]) -> None:
    """One error listing the outputs two inputs would both write, before anything is read.

    Two INPUT folders holding the same inner path (two drives' ``velodyne_points/data/0000000000.bin``)
    are not given a subfolder each: an output keeps its path inside its INPUT, as the masks of
    ``--holes`` are matched, and the folder holding both, given as one INPUT, keeps each one's folder.
    """
    pairs = list(dict.fromkeys((a, b) for a, b, _, _ in collisions))
    shown = "; ".join(f"{a} and {b} -> {o}" for a, b, o, _ in collisions[:3])
    more = f" and {len(pairs) - 3} more" if len(pairs) > 3 else ""
    if any(same for *_, same in collisions):
        how = ("the same path inside two INPUT folders: give the folder that holds them as one INPUT (each then "
               "keeps its own folder under --out), or fill them into separate --out folders")
    else:
        how = "rename one, or fill them into separate --out folders"
    raise InvalidInputError(f"{count(len(pairs), 'pair')} of inputs would be written to the same output ({shown}"
                            f"{more}): {how}; nothing was read")
