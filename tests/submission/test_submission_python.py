"""``inpaintenv.submission`` in Python: a notebook's round trip, run folders, manifest errors."""

from __future__ import annotations

import json

import numpy as np
import pytest

from inpaintenv.data import open_source, write_depth_png
from inpaintenv.submission import ManifestError, export, read_manifest, score


@pytest.fixture
def notebook(tmp_path, streets):
    """An export of four frames and median-filled predictions written as a notebook would."""
    manifest = export(tmp_path / "inputs", streets, "rect-v1", [0, 1], n_frames=4, progress=False, trusted=True)
    for item in manifest.items:
        depth, hole = manifest.read_input(item), manifest.read_hole(item)
        write_depth_png(tmp_path / "predictions" / item.input, np.where(hole, np.median(depth[depth > 0]), depth))
    return manifest, tmp_path / "predictions"


def test_score_into_a_run_folder_beside_other_methods(notebook, tmp_path):
    classical = pytest.importorskip("estimators.classical")
    manifest, predictions = notebook
    methods = {"nearest": classical.NearestInpainter()}
    result = score(manifest, predictions, name="median", out_dir=tmp_path / "run", methods=methods)
    assert sorted({r["method"] for r in result.rows}) == ["median", "nearest"] and len(result.rows) == 16
    assert result.meta["submission"]["scored"] == 8 and (tmp_path / "run" / "run.json").is_file()
    # A second call resumes: every row is read back from the run folder, none scored again.
    lines: list[str] = []
    again = score(manifest, predictions, name="median", out_dir=tmp_path / "run", methods=methods, log=lines.append)
    assert "16 already done, 0 to score" in lines[0]
    strip = lambda rows: [{k: v for k, v in r.items() if k != "ms"} for r in rows]
    assert strip(again.rows) == strip(result.rows)
    with pytest.raises(ValueError, match="also the name of a method"):
        score(manifest, predictions, name="nearest", out_dir=tmp_path / "run", methods=methods)
    with pytest.raises(ValueError, match="needs out_dir"):
        score(manifest, predictions, name="median", methods=methods)


def test_masks_drawn_differently_are_refused(notebook):
    manifest, predictions = notebook
    doc = json.loads(manifest.path.read_text())
    doc["items"][1]["hole_bits_sha256"] = "0" * 64
    manifest.path.write_text(json.dumps(doc))
    with pytest.raises(ManifestError, match="mask of frame 1 seed 0 drawn here differs"):
        score(manifest.path, predictions)


@pytest.mark.parametrize("text, message", [
    ("{not json", "not valid JSON"),
    ('{"format": "other"}', "not an inpaintenv export manifest"),
    ('{"format": "inpaintenv-submission", "format_version": 99}', "format version 99"),
    ('{"format": "inpaintenv-submission", "format_version": 2, "role": "score-key", "protocol": {"name": "rect-v1"}}',
     "lacks the field 'seeds'"),
])
def test_unreadable_manifests_say_why(tmp_path, text, message):
    (tmp_path / "manifest.json").write_text(text)
    with pytest.raises(ManifestError, match=message):
        read_manifest(tmp_path)


def test_missing_manifest(tmp_path):
    with pytest.raises(FileNotFoundError, match="no manifest at"):
        read_manifest(tmp_path / "nowhere" / "manifest.json")


def test_a_kitti_export_needs_a_root(kitti_root, tmp_path, monkeypatch):
    manifest = export(tmp_path / "inputs", open_source(kitti_root, split="val"), progress=False)
    (tmp_path / "predictions").mkdir()
    monkeypatch.delenv("INPAINTENV_KITTI_ROOT", raising=False)
    with pytest.raises(ValueError, match="pass --kitti-root"):
        score(manifest.path, tmp_path / "predictions")
