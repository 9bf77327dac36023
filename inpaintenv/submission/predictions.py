"""A folder of prediction PNGs: checked as a whole, then served to ``evaluate`` as a method.

:func:`check_predictions` reads the score key's ground truth and masks and every
prediction once, before anything is written, and reports every missing, unexpected,
refused or unusable file in one line. Only regular files inside the predictions folder
are read (no links, nothing larger than a PNG of the frame can be), and a prediction
must keep its input's measured pixels, which binds each file to the input it was made
for. :class:`SubmittedPredictions` is then an ordinary method for
:func:`inpaintenv.evaluate.evaluate` and the benchmark runner: it finds the prediction of
each input it is given by the input's content (:func:`~.layout.input_key`), so the rows,
masks and metrics are exactly those of any other method, on one machine or a cluster.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import stat
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..data.base import DepthDataset, name_from_path
from ..data.inputs import INPUTS, method_input
from ..data.io import depth_from_uint16
from ..masks import OcclusionProtocol, get_protocol
from .intervals import read_interval_files, split_interval_files
from .layout import (
    UnsafeFileError, decode_prediction, hole_bits_sha256, input_key, is_inside, max_png_bytes, read_inside,
)
from .manifest import Item, Manifest, ManifestError, require_key
from .truth import verify_frame
from ..exceptions import InvalidInputError, SubmissionError
from ..files import describe_kind, loads_json, read_bytes

__all__ = ["ON_MISSING", "CheckedPredictions", "SubmissionError", "SubmittedPredictions", "check_predictions",
           "manifest_protocol"]

#: Values of ``--on-missing``.
ON_MISSING = ("error", "skip")
_SHOWN = 3  # files named in a message before "and N more"


def _count(n: int, noun: str) -> str:
    return f"{n} {noun}{'s' * (n != 1)}"


def shown_name(rel: str) -> str:
    """``rel`` as a message shows it: a name that is not plain printable ASCII also with its code points
    escaped, so two names that print alike (NFC and NFD forms of one accent) read apart."""
    if rel.isascii() and rel.isprintable():
        return rel
    return f"{rel} [{rel.encode('ascii', 'backslashreplace').decode('ascii')}]"


def _listing(paths: list[str]) -> str:
    more = len(paths) - _SHOWN
    return ", ".join(shown_name(p) for p in paths[:_SHOWN]) + (f" and {more} more" if more > 0 else "")


def manifest_protocol(manifest: Manifest) -> OcclusionProtocol:
    """The installed protocol of ``manifest``, checked to be the one it was exported with.

    Raises
    ------
    ManifestError
        If the protocol is unknown here or its description (parameters) differs.
    """
    name = manifest.protocol_name
    try:
        proto = get_protocol(name)
    except KeyError:
        raise ManifestError(f"{manifest.path} was exported with protocol {name!r}, which this inpaintenv "
                            f"does not have; score with inpaintenv {manifest.inpaintenv_version}") from None
    here = loads_json(json.dumps(proto.describe()), "protocol description")  # as the manifest stores it
    if here != manifest.protocol.get("description"):
        raise ManifestError(f"protocol {name} here differs from the one {manifest.path} was exported with (its "
                            f"parameters changed); score with inpaintenv {manifest.inpaintenv_version}")
    return proto


class SubmittedPredictions:
    """A method that returns the predictions of a checked folder (see :func:`check_predictions`).

    Called like any batched method with ``(N, H, W)`` corrupted inputs; each input must be
    one of the manifest's. Each file is read again and checked against the sha256 taken
    when the folder was checked, so a file changed during the run is an error, not a
    silently different score.

    Attributes
    ----------
    name : str
    identity : str
        ``"predictions:<sha256>"`` of the scored files' names and bytes: a resumed run
        refuses rows made from other files under the same name.
    scored_pairs : frozenset of (int, int)
        The (seed, frame) pairs this folder has a prediction for; the benchmark runner
        scores only these.
    unfilled : {"error", "zero"}
        How :func:`inpaintenv.evaluate.evaluate` and the runner score a 0 at a pixel with
        ground truth: ``"zero"`` (as 0 m) when the folder was checked with
        ``allow_unfilled``, else ``"error"``.
    interval_kind : {"bounds", "std"} or None
        The interval files beside the predictions (:mod:`.intervals`), if any; then
        :attr:`predict_interval` reads them (it is None without).
    """

    batched = True

    def __init__(self, name: str, files: dict[str, tuple[str, str]], pairs: set[tuple[int, int]], identity: str,
                 unfilled: str = "error", folder: str | None = None,
                 intervals: dict[str, list[tuple[str, str]]] | None = None, interval_kind: str | None = None):
        self.name = name
        self.interval_kind = interval_kind if intervals and all(intervals.values()) else None
        self._intervals = dict(intervals or {})
        self.identity = identity
        self.scored_pairs = frozenset(pairs)
        self.unfilled = unfilled
        self._files = dict(files)
        self._folder = folder

    def __call__(self, x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=np.float32)
        out = np.empty_like(x)
        for k in range(len(x)):
            out[k] = depth_from_uint16(self._read(*self._entry(x[k]), x.shape[1:]))
        return out

    @property
    def predict_interval(self) -> Callable[..., tuple[np.ndarray, np.ndarray]] | None:
        """``predict_interval(X, coverage) -> (low, high)`` from the interval files; None without any.

        ``_low``/``_high`` files are the interval as given (whatever ``coverage`` is asked);
        a ``_std`` file gives the normal interval of ``coverage`` around the prediction.
        """
        return self._predict_interval if self.interval_kind else None

    def _predict_interval(self, x: np.ndarray, coverage: float = 0.9) -> tuple[np.ndarray, np.ndarray]:
        from ..metrics import interval_from_std  # lazy: only scoring with intervals needs it

        x = np.asarray(x, dtype=np.float32)
        low, high = np.empty(x.shape, np.float64), np.empty(x.shape, np.float64)
        for k in range(len(x)):
            key = input_key(x[k])
            self._entry(x[k])  # refuses an input without a prediction, as __call__ does
            maps = [depth_from_uint16(self._read(path, digest, x.shape[1:])) for path, digest in self._intervals[key]]
            if self.interval_kind == "std":
                low[k], high[k] = interval_from_std(depth_from_uint16(self._read(*self._files[key], x.shape[1:])),
                                                    maps[0], coverage)
            else:
                low[k], high[k] = maps
        return low, high

    def _entry(self, frame: np.ndarray) -> tuple[str, str]:
        entry = self._files.get(input_key(frame))
        if entry is None:
            raise SubmissionError(f"{self.name}: no prediction for this input (not one of the manifest's inputs, "
                                  "or one whose prediction was missing)")
        return entry

    def _read(self, path: str, digest: str, shape: tuple[int, ...]) -> np.ndarray:
        """The stored uint16 values of ``path``, read under the folder's rules and checked against ``digest``."""
        if self._folder is None:
            data = read_bytes(path, "prediction", limit=max_png_bytes(shape))
        else:  # the same rules as when the folder was checked: no links, nothing outside, bounded
            try:
                data = read_inside(Path(self._folder), path, max_png_bytes(shape))
            except (UnsafeFileError, OSError) as exc:
                raise SubmissionError(f"prediction {path} can no longer be read ({exc}); run score again") from None
        if hashlib.sha256(data).hexdigest() != digest:
            raise SubmissionError(f"prediction {path} changed while it was being scored; run score again")
        raw = decode_prediction(data, path, shape)  # type: ignore[arg-type]
        if isinstance(raw, str):
            raise SubmissionError(raw)
        return raw


@dataclass
class CheckedPredictions:
    """What :func:`check_predictions` found: the method to score, and what it left out."""

    method: SubmittedPredictions
    missing: list[str] = field(default_factory=list)
    unexpected: list[str] = field(default_factory=list)

    def left_out(self) -> str:
        """What ``on_missing="skip"`` left out, in words."""
        return (f"left out {_count(len(self.missing), 'missing prediction')}, ignored "
                f"{_count(len(self.unexpected), 'unlisted PNG file')}")

    def summary(self) -> dict[str, Any]:
        """JSON record of the submission for ``results.json``."""
        out = {"identity": self.method.identity, "scored": len(self.method.scored_pairs),
               "missing": self.missing, "unexpected": self.unexpected}
        if self.method.interval_kind is not None:
            out["intervals"] = self.method.interval_kind  # "bounds" (_low/_high files) or "std"
        return out


def _missing_hint(manifest: Manifest, unexpected: list[str]) -> str:
    """Why predictions may sit at other paths: another protocol's or export's tree."""
    tops = sorted({p.split("/", 1)[0] for p in unexpected if re.match(r"[^/]+/seed_\d+/", p)} - {manifest.protocol_name})
    if tops:
        return (f"; the folder holds predictions under {', '.join(f'{t}/' for t in tops)}, this manifest's inputs are "
                f"under {manifest.protocol_name}/: score them with the manifest of their own export")
    return ""


def _truth_files(dataset: DepthDataset) -> set[tuple[int, int]]:
    """``(device, inode)`` of every ground-truth file ``dataset`` reads (KITTI exports), to refuse hard links to them."""
    path = getattr(dataset, "path", None)
    found = set()
    for i in range(len(dataset) if callable(path) else 0):
        try:
            info = os.stat(path(i))  # type: ignore[misc]
        except OSError:
            continue  # named when the frame is read
        found.add((info.st_dev, info.st_ino))
    return found


def _scan(folder: Path, export: Path, truth: set[tuple[int, int]]) -> tuple[set[str], dict[str, str]]:
    """The regular ``.png`` files under ``folder`` (relative paths), and what is refused there (path -> why).

    Links are never followed (a link to a file or a folder, inside or out, is refused:
    ``score`` reads only files that lie in the predictions folder), a hard link to a
    ground-truth file (``truth``: its device and inode) is refused, and an export folder
    inside ``folder`` is left out. Bytes of a name that are not UTF-8 show as ``\\xNN``
    (no manifest path has them, so such a file is only ever reported).
    """
    inside = name_from_path(export.resolve().relative_to(folder.resolve()).as_posix()) + "/" \
        if is_inside(export, folder) else None
    found: set[str] = set()
    refused: dict[str, str] = {}
    for top, dirs, files in os.walk(folder, followlinks=False):
        base = Path(top)
        for name in list(dirs):
            if (base / name).is_symlink():
                dirs.remove(name)
                rel = name_from_path((base / name).relative_to(folder).as_posix())
                refused[rel] = f"{rel}/ is a symbolic link"
        for name in files:
            path = base / name
            rel = name_from_path(path.relative_to(folder).as_posix())
            if inside is not None and rel.startswith(inside):
                continue
            info = os.lstat(path)
            mode = info.st_mode
            if (info.st_dev, info.st_ino) in truth:
                refused[rel] = f"{rel} is a ground-truth file (a hard link to it)"
            elif stat.S_ISLNK(mode):
                if name.lower().endswith(".png"):
                    refused[rel] = f"{rel} is a symbolic link"
            elif name.lower().endswith(".png"):  # a .PNG is listed (as unexpected), never silently passed over
                if stat.S_ISREG(mode):
                    found.add(rel)
                else:
                    refused[rel] = f"{rel} is {describe_kind(mode)}, not a regular file"
    return found, refused


def _binding(raw: np.ndarray, expected: np.ndarray) -> int:
    """How many measured pixels of the input (``expected`` > 0) the prediction ``raw`` does not keep."""
    measured = expected > 0
    return int(np.count_nonzero(raw[measured] != expected[measured]))


def input_raw(inputs: np.ndarray, hole: np.ndarray) -> np.ndarray:
    """The uint16 values of the exported input: ``inputs`` (the ground truth, or the scan) with
    ``hole`` cut out, as ``write_depth_png`` rounds them."""
    return np.rint(np.where(hole, 0.0, np.asarray(inputs, dtype=np.float64)) * 256).astype(np.uint16)


def _whose(raw: np.ndarray, inputs: np.ndarray, item: Item, others: list[Item], proto: OcclusionProtocol,
           shape: tuple[int, int]) -> str:
    """Which other input of the same frame a prediction that does not keep its own input's pixels keeps, if any."""
    for other in others:
        if other is not item and _binding(raw, input_raw(inputs, proto.mask(shape, other.seed, other.index))) == 0:
            return f"; it is the prediction of {other.input} (seed {other.seed})"
    return ""


def _unfilled_pixels(raw: np.ndarray, x: np.ndarray, hole: np.ndarray, gt: np.ndarray, input_kind: str) -> int:
    """Pixels to fill that ``raw`` leaves at 0: a map's hole; a scan's unmeasured pixels with ground
    truth, the pixels ``evaluate`` refuses at 0 m (a densifier may leave the sky, where no truth is, empty)."""
    if INPUTS[input_kind].is_map:
        return int(np.count_nonzero(raw[hole] == 0))
    return int(np.count_nonzero((raw == 0) & np.isnan(x) & (gt > 0)))


def _problems(manifest: Manifest, folder: Path, n_expected: int, missing: list[str], unexpected: list[str],
              refused: list[str], bad: list[str], unfilled: list[str]) -> str:
    """Every problem of a predictions folder in one line ("" if none), so one look says everything to fix."""
    parts = []
    if missing:
        parts.append(f"{_count(len(missing), 'prediction')} of {n_expected} missing under {folder}: {_listing(missing)}")
    if unexpected:
        one = len(unexpected) == 1
        parts.append(f"{_count(len(unexpected), 'PNG file')} there {'is' if one else 'are'} not "
                     f"{'a prediction' if one else 'predictions'} of this manifest: {_listing(unexpected)}"
                     f"{_missing_hint(manifest, unexpected)}")
    if parts:
        parts[-1] += " (write each prediction at its input's relative path, or pass --on-missing skip)"
    if refused:
        parts.append(f"{_count(len(refused), 'file')} refused (score reads only regular files inside {folder}): "
                     f"{_listing(refused)}")
    if bad:
        parts.append(f"{_count(len(bad), 'prediction')} unusable: {_listing(bad)}")
    if unfilled:
        what, fill = ("hole pixels", "hole pixel") if INPUTS[manifest.input_kind].is_map else \
            ("unmeasured pixels with ground truth", "pixel the input did not measure")
        parts.append(f"{_count(len(unfilled), 'prediction')} with {what} left at 0 (unfilled): "
                     f"{_listing(unfilled)}; fill every {fill}, or pass --allow-unfilled to score 0 as 0 m")
    return "; ".join(parts)


def check_predictions(
    manifest: Manifest,
    dataset: DepthDataset,
    predictions: str | Path,
    *,
    name: str,
    on_missing: str = "error",
    allow_unfilled: bool = False,
    progress: Callable[[int], None] | None = None,
) -> CheckedPredictions:
    """Check the ground truth, the masks and every prediction of ``manifest``; build the method.

    Parameters
    ----------
    manifest : Manifest
    dataset : DepthDataset
        The manifest's ground truth (:func:`~.truth.open_truth`), frames in its order.
    predictions : path
        Folder holding ``<input's relative path>`` for every item of the manifest.
    name : str
        Method name of the submission.
    on_missing : {"error", "skip"}
        A missing prediction, or a PNG the manifest does not list, is an error ("error"), or
        is left out and recorded ("skip").
    allow_unfilled : bool
        Accept 0 (no depth) at hole pixels; they are then scored as 0 m.
    progress : callable, optional
        Called with 1 after every (frame, seed) checked.

    Raises
    ------
    ManifestError
        The protocol, a mask or a ground-truth frame differs from the export (named).
    FileNotFoundError
        A ground-truth file is missing, or ``predictions`` is not a folder.
    SubmissionError
        One line listing missing, unexpected, refused (links, not regular files, larger
        than :func:`~.layout.max_png_bytes`) and unusable predictions (not a 16-bit PNG
        of the frame, measured pixels of the input not kept, holes left at 0), and
        interval files (:mod:`.intervals`) that are partial (not all or none, of one
        kind), refused or unusable (not a 16-bit PNG of the frame, bounds inverted or not
        holding the prediction in the hole).
    """
    if on_missing not in ON_MISSING:
        raise InvalidInputError(f"on_missing must be 'error' or 'skip', got {on_missing!r}")
    folder = Path(predictions)
    if not folder.is_dir():
        raise FileNotFoundError(f"predictions folder {folder} does not exist")
    if folder.resolve() == manifest.root.resolve():
        raise SubmissionError(f"the predictions folder {folder} is the export itself (its inputs have 0 in the holes); "
                              "give the folder your method wrote")
    proto = manifest_protocol(manifest)
    shape = tuple(manifest.frame_shape)
    if tuple(dataset.frame_shape) != shape:
        raise ManifestError(f"the ground truth has frames of {dataset.frame_shape}, {manifest.path} of {shape}")
    require_key(manifest)
    expected = {item.input for item in manifest.items}
    present, refused_at = _scan(folder, manifest.root, _truth_files(dataset))
    refused = [refused_at[r] for r in sorted(refused_at)]
    behind = tuple(r + "/" for r in refused_at)  # paths under a refused (linked) folder: refused, not missing
    missing = sorted(p for p in expected - present - set(refused_at) if not p.startswith(behind))
    # Interval files beside a listed prediction (<name>_low/_high/_std.png, see .intervals) are not unexpected.
    beside, interval_kind, interval_problems = split_interval_files(expected, present)
    unexpected = sorted(present - expected - beside)
    if len(missing) == len(expected):
        raise SubmissionError(f"none of the {len(expected)} predictions of {manifest.path} is under {folder} (the "
                              f"first goes to {missing[0]}){_missing_hint(manifest, unexpected)}")

    by_frame: dict[int, list[Item]] = {}
    for item in manifest.items:
        by_frame.setdefault(item.index, []).append(item)
    bad: list[str] = list(interval_problems)
    unfilled: list[str] = []
    files: dict[str, tuple[str, str]] = {}
    intervals: dict[str, list[tuple[str, str]]] = {}
    pairs: set[tuple[int, int]] = set()
    digests: list[tuple[str, str]] = []
    kind = dataset.input_kind
    for frame in manifest.frames:
        inputs, gt = (a[0] for a in dataset.load_pairs([frame.index]))
        verify_frame(manifest, frame, gt, inputs)
        for item in by_frame.get(frame.index, []):
            hole = proto.mask(shape, item.seed, item.index)
            if hole_bits_sha256(hole) != item.hole_bits_sha256:
                raise ManifestError(
                    f"the {proto.name} mask of frame {item.index} seed {item.seed} drawn here differs from the "
                    f"exported one ({item.hole}); score with inpaintenv {manifest.inpaintenv_version}"
                )
            if progress is not None:
                progress(1)
            if item.input not in present:
                continue
            try:
                data = read_inside(folder, item.input, max_png_bytes(shape))
            except UnsafeFileError as exc:
                refused.append(str(exc))
                continue
            raw = decode_prediction(data, item.input, shape)  # type: ignore[arg-type]
            if isinstance(raw, str):
                bad.append(raw)
                continue
            changed = _binding(raw, input_raw(inputs, hole))
            if changed:
                # Binds each file to its input: a prediction saved under another input's name is caught here.
                bad.append(f"{item.input} does not keep {changed} of its input's measured pixels (a prediction keeps "
                           f"them as they are){_whose(raw, inputs, item, by_frame[frame.index], proto, shape)}")
                continue
            x = method_input(inputs, hole, kind)  # the input evaluate() builds for this (frame, seed)
            zeros = _unfilled_pixels(raw, x, hole, gt, kind)
            if zeros and not allow_unfilled:
                unfilled.append(f"{item.input} ({zeros} px)")
            entries = read_interval_files(folder, item.input, interval_kind, shape, raw, hole, refused, bad)
            digest = hashlib.sha256(data).hexdigest()
            key = input_key(x)
            if key in files and files[key][1] != digest:
                # Two (frame, seed) pairs with one input: evaluate() cannot tell them apart.
                bad.append(f"{item.input} differs from {files[key][0]} made for the same input")
            files[key] = (item.input, digest)
            digests.append((item.input, digest))
            intervals[key] = entries
            digests += entries  # other interval files, other identity: never resumed as the same rows
            pairs.add((item.seed, item.index))
    problems = _problems(manifest, folder, len(expected), missing if on_missing == "error" else [],
                         unexpected if on_missing == "error" else [], refused, bad, unfilled)
    if problems:
        raise SubmissionError(problems)
    h = hashlib.sha256()
    for rel, digest in sorted(digests):
        h.update(f"{rel}\0{digest}\n".encode())
    method = SubmittedPredictions(name, files, pairs, identity=f"predictions:{h.hexdigest()}",
                                  unfilled="zero" if allow_unfilled else "error", folder=str(folder),
                                  intervals=intervals, interval_kind=interval_kind)
    return CheckedPredictions(method=method, missing=missing, unexpected=unexpected)
