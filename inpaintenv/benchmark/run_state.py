"""The resume state of a run folder: ``run.json``, what keys a run, and why two runs differ.

``run.json`` fingerprints a run (source, frame ids, protocols, seeds, a run-wide
``unfilled``, and the data's content per drive, :mod:`.datakey`) and records what each
method name stood for (:mod:`.identity`) and the drives learned methods were trained on.
A resume into a folder of another run is refused with one line naming each setting that
differs (:func:`differences`).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from ..data.base import DepthDataset
from ..files import read_json, write_text_atomic
from .datakey import data_key
from ..files.ownership import claim
from ..exceptions import InpaintenvError, RunMismatchError, RunStateError

__all__ = ["RunMismatchError", "RunStateError", "differences", "fingerprint", "read_run_file", "run_fingerprint",
           "write_run_file"]


def fingerprint(dataset: DepthDataset, n_frames: int, protocols: Sequence[str], seeds: Sequence[int]) -> dict[str, Any]:
    """What keys a run: source, frames (count, ids), protocols, seeds and the data's content."""
    ids = "\n".join(str(f) for f in dataset.frame_ids[:n_frames])
    key = {
        "source": repr(dataset),
        "n_frames": n_frames,
        "frames_sha1": hashlib.sha1(ids.encode()).hexdigest(),
        "protocols": list(protocols),
        "seeds": list(seeds),
    }
    if not dataset.input.is_map:  # a scan run and a map run of one source are different runs
        key["input_kind"] = dataset.input_kind
    data = data_key(dataset, n_frames)
    if data:  # a generated source has nothing beyond its description
        key["data"] = data
    return key


def run_fingerprint(datasets: Mapping[str, DepthDataset], totals: Mapping[str, int], tasks: Sequence[Any],
                    seeds: Sequence[int]) -> dict[str, Any]:
    """What keys a run of tasks (:mod:`.tasks`): the :func:`fingerprint` of its one input kind (a run on
    maps keeps the key it always had), or, with tasks on several, that of the maps (else the first kind) with each
    other kind's under its name (``"scan"``, ``"scan-rings16-v1"``)."""
    kinds = list(dict.fromkeys(t.input_kind for t in tasks))
    keys = {k: fingerprint(datasets[k], totals[k], [t.protocol for t in tasks if t.input_kind == k], seeds)
            for k in kinds}
    if len(kinds) == 1:
        return keys[kinds[0]]
    key = keys[kinds[0]] if "map" not in keys else keys["map"]  # the map's, or the first kind's, as it always was
    for kind in kinds:
        if keys[kind] is not key:
            key[kind] = {k: v for k, v in keys[kind].items() if k not in ("seeds", "input_kind")}
    return key


def read_run_file(path: Path) -> dict[str, Any]:
    """The resume state of ``path``; a damaged file is an error that names it.

    Read as a file of a folder the run owns: a link, FIFO or device there is refused at
    once, and so is a document too large or nested too deeply (:func:`inpaintenv.files.read_json`).
    """
    try:
        state = read_json(path, "the file", follow_links=False)
    except FileNotFoundError:
        raise
    except (InpaintenvError, OSError) as exc:  # broken, too deep or large, a link or FIFO: named by exc
        raise RunStateError(f"cannot read the resume state ({exc}); pass --no-resume (resume=False) to start over, "
                            "or delete the file") from None
    if not isinstance(state, dict):
        raise RunStateError(
            f"{path} is not a benchmark resume state (a JSON object); pass --no-resume "
            "(resume=False) to start over, or delete the file"
        )
    return state


def write_run_file(
    path: Path, fingerprint: dict[str, Any], identities: dict[str, str], trained: dict[str, list[str]]
) -> None:
    # Whole or not at all: a kill mid-write must not leave a run.json that cannot be read.
    # "training_drives" is kept so that a resume that builds no method still marks them.
    claim(path.parent, path.name)
    write_text_atomic(path, json.dumps({**fingerprint, "methods": identities, "training_drives": trained}, indent=1))


#: What each fingerprint key is, for the message of a folder holding another run.
_SETTINGS = {
    "source": "the data source", "n_frames": "the number of frames", "frames_sha1": "the frames (their ids)",
    "protocols": "the protocols (--protocol)", "seeds": "the seeds (--seed)", "unfilled": "--unfilled",
    "input_kind": "the input (--input)", "scan": "the scan tasks (their source, frames, protocols or data)",
}


def differences(previous: dict[str, Any], now: dict[str, Any]) -> list[str]:
    """One phrase per setting in which the folder's run and this one differ."""
    out = []
    for key in [*_SETTINGS, *sorted((set(previous) | set(now)) - set(_SETTINGS) - {"data"})]:
        before, after = previous.get(key), now.get(key)
        if before == after:
            continue
        if key == "unfilled":
            before = before or "not given (each method's own policy)"
            after = after or "not given (each method's own policy)"
        out.append(f"{_SETTINGS.get(key, key)}: {before} there, {after} now")
    old_data, new_data = previous.get("data"), now.get("data")
    if old_data is not None and old_data != new_data and previous.get("frames_sha1") == now.get("frames_sha1"):
        changed = sorted(d for d in set(old_data) | set(new_data or {}) if old_data.get(d) != (new_data or {}).get(d))
        shown = ", ".join(changed[:3]) + (f" and {len(changed) - 3} more" if len(changed) > 3 else "")
        out.append(f"the ground truth changed since its rows were scored (the files of drive{'s' * (len(changed) != 1)} "
                   f"{shown} differ in size, modification time or content)")
    return out
