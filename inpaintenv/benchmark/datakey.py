"""What the ground truth of a run *contains*, per drive, so a resume notices changed data.

Frame ids say which frames a run scores, not what is in them: halving every
ground-truth PNG keeps the ids. The run's fingerprint therefore also holds, per drive,
a digest of its frames' content as far as it is cheap to know:

* frames read from files (``KittiDepth``, an export's ground truth): each file's path,
  size and modification time (``os.stat``; no file is read; a scan input's file too), and for an export's
  ground truth the sha256 its manifest records;
* frames held in memory (``ArrayDataset``): the bytes of the arrays (and of its scans);
* generated frames (``SyntheticStreets``): nothing beyond the source's description,
  which holds every parameter of the generator.

A copy of the data with new modification times therefore reads as changed data: the
resume is refused and names the drives (``--no-resume`` rescored them).
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Iterator
from typing import Any

import numpy as np

from ..data.base import ArrayDataset, ConcatDataset, DepthDataset, Subset

__all__ = ["data_key"]


def _frame_facts(dataset: DepthDataset, index: int) -> Iterator[bytes]:
    """What is cheaply known about the content of frame ``index`` (nothing for generated frames)."""
    while True:  # walk down views to the dataset that holds the frame
        if isinstance(dataset, Subset):
            dataset, index = dataset.parent, int(dataset.indices[index])
        elif isinstance(dataset, ConcatDataset):
            part = int(np.searchsorted(dataset._offsets, index, side="right")) - 1
            dataset, index = dataset.parts[part], int(index - dataset._offsets[part])
        elif isinstance(getattr(dataset, "dataset", None), DepthDataset):  # a cache of another source
            dataset = dataset.dataset
        else:
            break
    if isinstance(dataset, ArrayDataset):
        yield hashlib.sha1(np.ascontiguousarray(dataset._frames[index]).tobytes()).digest()
        if dataset._inputs is not None:
            yield hashlib.sha1(np.ascontiguousarray(dataset._inputs[index]).tobytes()).digest()
        return
    recorded = getattr(dataset, "_frames", None)
    sha = getattr(recorded[index], "ground_truth_sha256", None) if isinstance(recorded, list) else None
    if isinstance(sha, str):
        yield sha.encode()
    scans = getattr(dataset, "input_paths", None)
    scan = scans[index] if isinstance(scans, list) and dataset.input.separate else None
    for path in (_frame_path(dataset, index), scan):  # a scan's file too: its changes change the run
        if path is None:
            continue
        try:
            st = os.stat(path)
        except OSError:
            yield os.fsencode(path) + b"|missing"
        else:
            yield os.fsencode(path) + f"|{st.st_size}|{st.st_mtime_ns}".encode()


def _frame_path(dataset: DepthDataset, index: int) -> Any:
    """The file frame ``index`` is read from (``KittiDepth.paths``, ``ManifestFrames.path``), else None."""
    paths = getattr(dataset, "paths", None)
    if isinstance(paths, list):
        return paths[index]
    path = getattr(dataset, "path", None)
    return path(index) if callable(path) else None


def data_key(dataset: DepthDataset, n_frames: int) -> dict[str, str]:
    """Per drive of the first ``n_frames`` frames, a digest of what is cheaply known of their content.

    Returns
    -------
    dict of str to str
        Drive -> 16 hex digits; empty when nothing is known beyond the frame ids (a
        generated source, whose description already fixes its frames).
    """
    digests: dict[str, Any] = {}
    known = False
    for i in range(n_frames):
        h = digests.setdefault(str(dataset.groups[i]), hashlib.sha1())
        h.update(str(dataset.frame_ids[i]).encode("utf-8", "surrogateescape") + b"\0")
        for fact in _frame_facts(dataset, i):
            known = True
            h.update(fact + b"\0")
    return {drive: h.hexdigest()[:16] for drive, h in digests.items()} if known else {}
