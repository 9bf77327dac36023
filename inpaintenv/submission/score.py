"""Score a folder of predictions against the ground truth an export was made from.

The submission becomes an ordinary method (:class:`~.predictions.SubmittedPredictions`) and
is scored by :func:`inpaintenv.evaluate.evaluate` -- the same masks, rows and metrics as
any method scored in-process -- or, with ``out_dir``, by the benchmark runner, so its rows
land in a resumable run folder beside those of the methods scored in the same call.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from ..data.base import DepthDataset
from ..data.kitti import KITTI_ROOT_ENV
from ..evaluate import evaluate
from ..report.results import EvaluationResult
from ..metrics import as_coverage
from .layout import is_inside
from .manifest import Manifest, read_manifest, require_key
from .predictions import CheckedPredictions, check_predictions
from .truth import open_truth
from ..exceptions import InvalidInputError

__all__ = ["check_run_folder", "prepare", "score", "submission_meta", "without_ms"]


def prepare(
    manifest: str | os.PathLike | Manifest,
    predictions: str | os.PathLike,
    *,
    name: str,
    kitti_root: str | os.PathLike | None = None,
    source: DepthDataset | None = None,
    on_missing: str = "error",
    allow_unfilled: bool = False,
    progress: bool = False,
) -> tuple[Manifest, DepthDataset, CheckedPredictions]:
    """Read the manifest, open its ground truth and check every prediction.

    The parameters are those of :func:`score`; nothing is scored or written.

    Returns
    -------
    manifest : Manifest
    dataset : DepthDataset
        The ground truth, frames in the manifest's order.
    checked : CheckedPredictions
        ``checked.method`` is the submission as a method.
    """
    if not isinstance(name, str) or not name.strip():
        raise InvalidInputError(f"name must be a non-empty string, got {name!r}")
    m = require_key(manifest if isinstance(manifest, Manifest) else read_manifest(manifest))
    if kitti_root is None and source is None and m.ground_truth.get("type") == "kitti":
        kitti_root = os.environ.get(KITTI_ROOT_ENV) or None
    dataset = open_truth(m, kitti_root, source)
    from tqdm.auto import tqdm  # lazy: only needed when looping

    with tqdm(total=len(m.items), desc="check predictions", unit="file", disable=None if progress else True,
              leave=False) as bar:
        checked = check_predictions(m, dataset, predictions, name=name, on_missing=on_missing,
                                    allow_unfilled=allow_unfilled, progress=bar.update)
    return m, dataset, checked


def check_run_folder(out: str | os.PathLike, manifest: Manifest, predictions: str | os.PathLike) -> Path:
    """``out`` as a Path if it may hold the run: not a file, writable, outside the export and the predictions.

    Raises
    ------
    ValueError
        Naming the folder it lies in (its figures would become unlisted PNG files there).
    """
    path = Path(out)
    if path.exists() and not path.is_dir():
        raise InvalidInputError(f"--out {path} is a file; give a folder for the run")
    existing = next((p for p in (path, *path.absolute().parents) if p.exists()), None)
    if existing is not None and not os.access(existing, os.W_OK | os.X_OK):
        raise InvalidInputError(f"--out {path}: cannot write the run folder there ({existing} is on a read-only disk or "
                                "not writable by you); give a folder you can write to")
    for folder, what in ((manifest.root, "export"), (Path(predictions), "predictions")):
        if is_inside(path, folder):
            raise InvalidInputError(f"--out {path} lies in the {what} folder {folder}; give a run folder outside it")
    return path


def submission_meta(name: str, manifest: Manifest, predictions: str | os.PathLike,
                    checked: CheckedPredictions) -> dict[str, Any]:
    """``meta["submission"]`` of a scored folder: where it came from, whether its export was ``trusted``
    (several seeds per frame), its identity, what was left out."""
    return {"name": name, "manifest": str(manifest.path), "predictions": str(predictions),
            "trusted": manifest.trusted, **checked.summary()}


def without_ms(result: EvaluationResult, name: str) -> EvaluationResult:
    """``result`` with ``ms`` = NaN in the rows of ``name``: its time was reading files, not running a method."""
    rows = [{**r, "ms": math.nan} if r["method"] == name else r for r in result.rows]
    return EvaluationResult(rows=rows, meta=dict(result.meta))


def score(
    manifest: str | os.PathLike | Manifest,
    predictions: str | os.PathLike,
    *,
    name: str = "submission",
    kitti_root: str | os.PathLike | None = None,
    source: DepthDataset | None = None,
    on_missing: str = "error",
    allow_unfilled: bool = False,
    out_dir: str | os.PathLike | None = None,
    methods: Mapping[str, Any] | None = None,
    resume: bool = True,
    batch_size: int = 4,
    progress: bool = False,
    log: Callable[[str], None] | None = None,
    interval_coverage: float = 0.9,
) -> EvaluationResult:
    """Score the predictions in ``predictions`` for the inputs of ``manifest``.

    Everything is checked before anything is scored or written: the protocol and every
    mask against the manifest, every ground-truth frame against its recorded sha256, and
    every prediction (present, a 16-bit single-channel PNG of the frame's size, no 0 in
    a hole pixel). Problems with predictions are reported together in one
    :class:`~.predictions.SubmissionError`.

    Parameters
    ----------
    manifest : path-like or Manifest
        ``manifest.json`` of an export, or its folder.
    predictions : path-like
        Folder holding one prediction per input, at the input's relative path (16-bit
        PNG, metres × 256).
    name : str
        Method name of the submission in the rows.
    kitti_root : path-like, optional
        Root holding the ground truth of a KITTI export (default ``$INPAINTENV_KITTI_ROOT``).
    source : DepthDataset, optional
        The dataset of an export made in Python from a custom dataset.
    on_missing : {"error", "skip"}
        Missing predictions (and PNG files the manifest does not list) stop the scoring
        ("error") or are left out ("skip"; listed in ``meta["submission"]``).
    allow_unfilled : bool
        Score 0 at hole pixels as 0 m instead of refusing the prediction.
    out_dir : path-like, optional
        Write the rows into this benchmark run folder (resumable; ``rows/``, ``run.json``)
        through :func:`inpaintenv.benchmark.run_benchmark`. The report files are the CLI's
        job (:func:`inpaintenv.benchmark.write_report`).
    methods : mapping of str to method, optional
        More methods to score on the same frames and masks in the same run (needs
        ``out_dir``), e.g. ``{"harmonic": make_method("harmonic")}``.
    resume : bool
        Keep rows already in ``out_dir``.
    batch_size : int
        Frames per batch.
    progress : bool
        Progress bars on stderr (when it is a terminal).
    log : callable, optional
        Receives the run's messages.
    interval_coverage : float
        Nominal coverage (in (0, 1); 0.9 by default) of the interval files beside the
        predictions, when the folder has them (``<name>_low.png`` / ``<name>_high.png``
        or ``<name>_std.png``, see :mod:`.intervals`): the rows then gain the interval
        columns of :func:`~inpaintenv.evaluate.evaluate`'s ``intervals``, and a ``_std``
        file becomes the normal interval of this coverage. Unused without interval files.

    Returns
    -------
    EvaluationResult
        Per-frame rows as :func:`~inpaintenv.evaluate.evaluate` makes them; the
        submission's ``ms`` is NaN (it ran elsewhere). ``meta["submission"]`` records the
        manifest, the folder, the predictions' identity and what was missing.

    Raises
    ------
    ManifestError, SubmissionError
        See :func:`~.predictions.check_predictions` (both are ``ValueError``).
    FileNotFoundError
        A missing manifest, predictions folder or ground-truth file (named).
    """
    extra = dict(methods or {})
    if name in extra:
        raise InvalidInputError(f"the submission's name {name!r} is also the name of a method of the run; choose another")
    if extra and out_dir is None:
        raise InvalidInputError("methods= needs out_dir= (a run folder holds the rows of several methods)")
    m, dataset, checked = prepare(manifest, predictions, name=name, kitti_root=kitti_root, source=source,
                                  on_missing=on_missing, allow_unfilled=allow_unfilled, progress=progress)
    say = log or (lambda msg: None)
    if checked.missing or checked.unexpected:
        say(f"{name}: {checked.left_out()} (on_missing='skip')")
    method = checked.method
    interval_coverage = as_coverage(interval_coverage, "interval_coverage")
    # Asked only when the folder has interval files: a folder without keeps the rows and run it always had.
    coverage = interval_coverage if method.interval_kind is not None else None
    if out_dir is None:
        parts = []
        for seed in m.seeds:
            indices = sorted(i for s, i in method.scored_pairs if s == seed)
            if indices:
                parts.append(evaluate(method, dataset, m.protocol_name, seeds=[seed], indices=indices,
                                      batch_size=batch_size, progress=progress, name=name, unfilled=method.unfilled,
                                      intervals=coverage))
        result = EvaluationResult.concat(parts)
        result.meta.update({"seeds": m.seeds})
    else:
        from ..benchmark.runner import run_benchmark

        out_dir = check_run_folder(out_dir, m, predictions)
        result = run_benchmark(
            {name: method, **extra}, dataset, protocols=[m.protocol_name], seeds=m.seeds, out_dir=Path(out_dir),
            resume=resume, batch_size=batch_size, progress=progress, log=say, interval_coverage=coverage,
        )
    result = without_ms(result, name)
    result.meta["submission"] = submission_meta(name, m, predictions, checked)
    return result
