"""Per-pixel intervals beside a submission's predictions: ``<name>_low.png`` / ``<name>_high.png`` or ``<name>_std.png``.

Beside a prediction ``<dir>/<name>.png`` a submission may put its interval as two PNG
files, ``<name>_low.png`` and ``<name>_high.png`` (the bounds), or one, ``<name>_std.png``
(a standard deviation: the interval is then ``[pred - z·std, pred + z·std]`` clipped at
0 m, ``z`` the normal quantile of the coverage scored). They are encoded as predictions
are (16-bit single-channel PNG of the frame's size, metres × 256; 0 is 0 m) and read under
the same rules (regular files inside the predictions folder, no links, at most
:func:`~.layout.max_png_bytes`). All or none: either every scored prediction has the same
kind of interval, or none has; a partial set (a ``_low`` without its ``_high``, an
interval beside some predictions only, ``_std`` beside one and ``_low``/``_high`` beside
another) is refused with one line naming the files. In the hole the bounds must satisfy
``low <= prediction <= high``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

#: Suffixes (before ``.png``) of each kind of interval file.
KINDS: dict[str, tuple[str, ...]] = {"bounds": ("_low", "_high"), "std": ("_std",)}
_SUFFIXES = ("_low", "_high", "_std")

__all__ = ["KINDS", "check_bounds", "interval_files", "read_interval_files", "sidecar", "sidecar_kinds",
           "split_interval_files"]


def sidecar(rel: str, suffix: str) -> str:
    """The path of the ``suffix`` file (``_low``, ``_high``, ``_std``) beside the prediction ``rel``."""
    p = Path(rel)
    return p.with_name(p.stem + suffix + p.suffix).as_posix()


def interval_files(expected: set[str], present: set[str]) -> dict[str, set[str]]:
    """Per prediction path of ``expected``: the suffixes of its interval files among ``present``."""
    return {rel: {s for s in _SUFFIXES if sidecar(rel, s) in present} for rel in expected}


def sidecar_kinds(found: dict[str, set[str]], scored: set[str]) -> tuple[str | None, list[str]]:
    """The submission's kind of interval (``"bounds"``, ``"std"`` or None) and its problems (phrases).

    ``found`` is :func:`interval_files`'s result, ``scored`` the predictions present.
    """
    problems: list[str] = []
    kinds: dict[str, list[str]] = {}
    for rel in sorted(scored):
        have = found.get(rel, set())
        if not have:
            kinds.setdefault("none", []).append(rel)
        elif have == {"_low", "_high"}:
            kinds.setdefault("bounds", []).append(rel)
        elif have == {"_std"}:
            kinds.setdefault("std", []).append(rel)
        else:
            names = ", ".join(sidecar(rel, s) for s in sorted(have))
            problems.append(f"{rel} has {names}: an interval is {sidecar(rel, '_low')} and {sidecar(rel, '_high')}, "
                            f"or {sidecar(rel, '_std')}")
    given = [k for k in ("bounds", "std") if k in kinds]
    if len(given) > 1 or (given and "none" in kinds):
        counts = ", ".join(f"{len(v)} with {'no interval' if k == 'none' else k + ' files'} (e.g. {v[0]})"
                           for k, v in kinds.items())
        problems.append(f"intervals are all or none, of one kind: {counts}")
    # With any problem nothing is read: the one error lists them all.
    return (given[0] if len(given) == 1 and not problems else None), problems


def check_bounds(rel: str, pred: np.ndarray, low: np.ndarray, high: np.ndarray, hole: np.ndarray) -> str | None:
    """What is wrong with the stored bounds of ``rel`` in the hole (one phrase), or None.

    All three are the stored uint16 values, so the comparisons are exact.
    """
    p, lo, hi = pred[hole], low[hole], high[hole]
    if n := int(np.count_nonzero(lo > hi)):
        return f"{sidecar(rel, '_low')} is above {sidecar(rel, '_high')} at {n} hole pixels (inverted)"
    if n := int(np.count_nonzero((lo > p) | (p > hi))):
        return f"the interval of {rel} does not hold the prediction at {n} hole pixels (low <= prediction <= high)"
    return None


def split_interval_files(expected: set[str], present: set[str]) -> tuple[set[str], str | None, list[str]]:
    """``(interval files beside a listed prediction, the submission's kind, problems)`` (see :func:`sidecar_kinds`)."""
    found = interval_files(expected, present)
    beside = {sidecar(rel, s) for rel, have in found.items() for s in have}
    kind, problems = sidecar_kinds(found, expected & present)
    return beside, kind, problems


def read_interval_files(
    folder: Path, rel: str, kind: str | None, shape: tuple[int, int], pred: np.ndarray, hole: np.ndarray,
    refused: list[str], bad: list[str],
) -> list[tuple[str, str]]:
    """Read and check the interval files of the prediction ``rel`` (stored values ``pred``).

    Returns ``(path, sha256)`` of each file read (none when ``kind`` is None), and appends
    to ``refused`` the files refused (links, not regular, too large) and to ``bad`` the
    unusable ones (not a 16-bit PNG of the frame, bounds inverted or not holding the
    prediction in the hole).
    """
    if kind is None:
        return []
    import hashlib

    from .layout import UnsafeFileError, decode_prediction, max_png_bytes, read_inside

    entries: list[tuple[str, str]] = []
    raws: list[np.ndarray] = []
    for suffix in KINDS[kind]:
        path = sidecar(rel, suffix)
        try:
            data = read_inside(folder, path, max_png_bytes(shape))
        except UnsafeFileError as exc:
            refused.append(str(exc))
            continue
        raw = decode_prediction(data, path, shape)
        if isinstance(raw, str):
            bad.append(raw)
            continue
        entries.append((path, hashlib.sha256(data).hexdigest()))
        raws.append(raw)
    if kind == "bounds" and len(raws) == 2 and (problem := check_bounds(rel, pred, raws[0], raws[1], hole)):
        bad.append(problem)
    return entries
