"""Tampered score keys and hostile prediction folders: one ManifestError / SubmissionError, never
a traceback from deep inside, a dropped item, a truncated number or a file read from elsewhere."""

from __future__ import annotations

import copy
import json
import os
import shutil

import numpy as np
import pytest
from fuzz_settings import fast
from hypothesis import given
from hypothesis import strategies as st

from inpaintenv.data import SyntheticStreets, write_depth_png
from inpaintenv.submission import ManifestError, SubmissionError, export, read_manifest, score
from inpaintenv.submission.layout import max_png_bytes

SHAPE = (32, 64)

json_values = st.recursive(
    st.none() | st.booleans() | st.integers(-(2**70), 2**70) | st.floats(allow_nan=True) | st.text(max_size=12),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=6), inner, max_size=3),
    max_leaves=6,
)
#: Fields of a score key that a tampering may change (a path into the JSON document).
FIELDS = [
    ("seeds",), ("seeds", 0), ("frame_shape",), ("frame_shape", 0), ("frame_shape", 1), ("trusted",), ("role",),
    ("kit",), ("protocol",), ("protocol", "name"), ("frames",), ("frames", 0), ("frames", 1, "index"),
    ("frames", 0, "position"), ("frames", 0, "ground_truth_sha256"), ("items",), ("items", 0), ("items", 1, "index"),
    ("items", 0, "seed"), ("items", 0, "input"), ("items", 2, "hole"), ("items", 0, "hole_bits_sha256"),
    ("ground_truth",), ("ground_truth", "type"), ("ground_truth", "n"), ("ground_truth", "seed"),
    ("ground_truth", "kind"), ("ground_truth", "frame_shape"), ("ground_truth", "frames_per_drive"),
]


@pytest.fixture(scope="module")
def kit(tmp_path_factory):
    """A one-seed export of three small frames, its key's document and hole-filled predictions."""
    tmp = tmp_path_factory.mktemp("fuzz-manifest")
    manifest = export(tmp / "inputs", SyntheticStreets(n=3, frame_shape=SHAPE, frames_per_drive=2), progress=False)
    for item in manifest.items:
        write_depth_png(tmp / "predictions" / item.input,
                        np.where(manifest.read_hole(item), 7.0, manifest.read_input(item)))
    return tmp, manifest, json.loads(manifest.path.read_text())


def set_field(doc, path, value):
    box = doc
    for step in path[:-1]:
        box = box[step]
    box[path[-1]] = value


@fast(120)
@given(field=st.sampled_from(FIELDS), value=json_values)
def test_a_tampered_key_is_refused_in_one_clear_error_or_scored_as_recorded(kit, field, value):
    tmp, manifest, doc = kit
    tampered = copy.deepcopy(doc)
    set_field(tampered, field, value)
    path = tmp / "tampered.key.json"
    path.write_text(json.dumps(tampered))
    try:
        m = read_manifest(path)
        result = score(m, tmp / "predictions")
    except (ManifestError, SubmissionError) as exc:
        assert "\n" not in str(exc) and str(exc)
        return
    # What is accepted scores every (frame, seed) the key lists, as recorded: nothing dropped.
    assert len(result.rows) == len(m.items) == len(m.seeds) * len(m.frames)
    assert all(isinstance(s, int) and not isinstance(s, bool) for s in m.seeds)


@fast(30)
@given(frames=st.integers(-3, 2**40), seeds=st.lists(st.integers(-2, 2**64), max_size=4))
def test_declared_sizes_and_seeds_are_bounded(kit, frames, seeds):
    tmp, _, doc = kit
    tampered = copy.deepcopy(doc)
    tampered["frame_shape"] = [frames, frames]
    tampered["ground_truth"]["n"] = frames
    tampered["seeds"] = seeds
    path = tmp / "sized.key.json"
    path.write_text(json.dumps(tampered))
    with pytest.raises((ManifestError, SubmissionError)):
        score(read_manifest(path), tmp / "predictions")


def spoil(kind, predictions, manifest, size):
    """Make one prediction file hostile; returns the phrase the one-line error must hold."""
    target = predictions / manifest.items[1].input
    if kind == "link-out":
        target.unlink()
        target.symlink_to("/etc/passwd")
        return "is a symbolic link"
    if kind == "link-in":  # even a link to another prediction of the folder
        target.unlink()
        target.symlink_to(predictions / manifest.items[0].input)
        return "is a symbolic link"
    if kind == "linked-folder":
        folder = target.parent
        shutil.move(folder, predictions.parent / "moved")
        folder.symlink_to(predictions.parent / "moved")
        return "/ is a symbolic link"
    if kind == "sparse":
        with open(target, "r+b") as f:
            f.truncate(size)
        return "a 16-bit PNG of the frame can need"
    if kind == "swapped":
        other = predictions / manifest.items[2].input
        data = target.read_bytes()
        target.write_bytes(other.read_bytes())
        other.write_bytes(data)
        return "does not keep"
    if kind == "fifo":
        target.unlink()
        os.mkfifo(target)
        return "not a regular file"
    raise AssertionError(kind)


@fast(20)
@given(kind=st.sampled_from(["link-out", "link-in", "linked-folder", "sparse", "swapped", "fifo"]),
       extra=st.integers(1, 2**40))
def test_hostile_prediction_files_are_one_line(kit, tmp_path_factory, kind, extra):
    tmp, manifest, _ = kit
    predictions = tmp_path_factory.mktemp("hostile") / "predictions"
    shutil.copytree(tmp / "predictions", predictions)
    word = spoil(kind, predictions, manifest, max_png_bytes(SHAPE) + extra)
    with pytest.raises(SubmissionError) as info:
        score(manifest, predictions)
    message = str(info.value)
    assert "\n" not in message and word in message, message
