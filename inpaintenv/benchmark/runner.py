"""Run a suite of methods over a data source and protocols, resumably.

Per-frame rows are appended to ``<out>/rows/<method>__<protocol>.jsonl`` as soon as a
batch is scored, so a killed run continues where it stopped: on restart, every
(seed, frame) already in the file is skipped. ``<out>/run.json`` fingerprints the run
(source, frames, protocols, seeds); resuming into a folder of a different run is an error.
"""

from __future__ import annotations

import hashlib
import json
import re
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from ..data.base import DepthDataset
from ..evaluate import EvaluationResult, parse_row, evaluate, resolve_source
from ..masks import get_protocol

__all__ = ["run_benchmark", "RunMismatchError"]


#: Errors meaning "this method cannot be built here" (missing package or weights).
UNAVAILABLE = (ImportError, KeyError, FileNotFoundError)


class RunMismatchError(ValueError):
    """The output folder holds rows of a different run (other data, seeds or protocols)."""


def _slug(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name)


def _fingerprint(dataset: DepthDataset, n_frames: int, protocols: Sequence[str], seeds: Sequence[int]) -> dict[str, Any]:
    ids = "\n".join(str(f) for f in dataset.frame_ids[:n_frames])
    return {
        "source": repr(dataset),
        "n_frames": n_frames,
        "frames_sha1": hashlib.sha1(ids.encode()).hexdigest(),
        "protocols": list(protocols),
        "seeds": list(seeds),
    }


def _read_rows(path: Path) -> list[dict[str, Any]]:
    rows = []
    if path.exists():
        for line in path.read_text().splitlines():
            if not line.strip():
                continue
            try:
                rows.append(parse_row(json.loads(line)))
            except json.JSONDecodeError:
                # A run killed mid-write leaves at most one partial last line.
                continue
    return rows


def run_benchmark(
    methods: Mapping[str, Any],
    source: Any = None,
    *,
    protocols: Sequence[str] = ("rect-v1",),
    seeds: Sequence[int] = (0,),
    n_frames: int | None = None,
    out_dir: str | Path = "benchmark-results",
    resume: bool = True,
    batch_size: int = 4,
    progress: bool = True,
    log: Callable[[str], None] | None = None,
) -> EvaluationResult:
    """Score every method under every protocol and seed; return all per-frame rows.

    Parameters
    ----------
    methods : mapping of str to method
        Display name -> callable or estimator (see :func:`inpaintenv.evaluate.evaluate`).
        Values may also be zero-argument factories marked with ``lazy=True`` attribute;
        they are only built when some frame still needs scoring.
    source : DepthDataset, array or None
        Ground truth to score on (None: the built-in SyntheticStreets default).
    protocols, seeds : sequences
        Occlusion protocols by name and evaluation seeds.
    n_frames : int, optional
        Only the first ``n_frames`` frames.
    out_dir : path
        Folder for ``run.json`` and the per-method row files.
    resume : bool
        Keep rows already in ``out_dir`` and score only what is missing. With False the
        folder's row files are replaced.

    Returns
    -------
    EvaluationResult
        Rows of every (method, protocol, seed, frame), methods in the given order.
    """
    dataset = resolve_source(source)
    total = len(dataset) if n_frames is None else min(len(dataset), int(n_frames))
    protocols = [get_protocol(p).name for p in protocols]
    seeds = [int(s) for s in seeds]
    out = Path(out_dir)
    rows_dir = out / "rows"
    rows_dir.mkdir(parents=True, exist_ok=True)
    fingerprint = _fingerprint(dataset, total, protocols, seeds)
    run_file = out / "run.json"
    if resume and run_file.exists():
        previous = json.loads(run_file.read_text())
        if previous != fingerprint:
            raise RunMismatchError(
                f"{out} holds results of a different run ({previous.get('source')}, "
                f"protocols {previous.get('protocols')}, seeds {previous.get('seeds')}); "
                "choose another --out or pass --no-resume to overwrite"
            )
    run_file.write_text(json.dumps(fingerprint, indent=1))
    say = log or (lambda msg: None)

    results: list[EvaluationResult] = []
    for name, method in methods.items():
        for protocol in protocols:
            path = rows_dir / f"{_slug(name)}__{_slug(protocol)}.jsonl"
            if not resume and path.exists():
                path.unlink()
            done_rows = [r for r in _read_rows(path) if r["method"] == name]
            done = {(r["seed"], r["index"]) for r in done_rows}
            todo = {s: [i for i in range(total) if (s, i) not in done] for s in seeds}
            n_todo = sum(len(v) for v in todo.values())
            if n_todo:
                say(f"{name} / {protocol}: {n_todo} frames to score ({len(done)} already done)")
            if n_todo and getattr(method, "lazy", False):
                try:
                    method = method()
                except UNAVAILABLE as exc:
                    if not getattr(method, "optional", False):
                        raise
                    say(f"skipping {name!r}: not available here ({exc})")
                    break
            if path.exists() and path.stat().st_size and not path.read_bytes().endswith(b"\n"):
                # A kill mid-write left a partial last line: end it so new rows start clean.
                with path.open("a") as f:
                    f.write("\n")
            with path.open("a") as f:

                def append(batch_rows: list[dict[str, Any]]) -> None:
                    for row in batch_rows:
                        f.write(json.dumps(row) + "\n")
                    f.flush()

                for seed, indices in todo.items():
                    if not indices:
                        continue
                    evaluate(
                        method, dataset, protocol, seeds=[seed], indices=indices,
                        batch_size=batch_size, progress=progress, name=name, on_batch=append,
                    )
            keep = {(s, i) for s in seeds for i in range(total)}
            rows = [r for r in _read_rows(path) if r["method"] == name and (r["seed"], r["index"]) in keep]
            # One row per (seed, frame) even if a crash left a duplicate line behind.
            unique = {(r["seed"], r["index"]): r for r in rows}
            ordered = [unique[k] for k in sorted(unique)]
            results.append(EvaluationResult(rows=ordered, meta={"methods": [name]}))
    if not results:
        raise ValueError("no method could be run here (see the messages above)")
    combined = EvaluationResult.concat(results)
    combined.meta.update(
        {"source": repr(dataset), "protocols": protocols, "seeds": seeds, "n_frames": total}
    )
    return combined
