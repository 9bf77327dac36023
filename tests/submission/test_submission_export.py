"""``export``: what the files and the manifest hold, byte-identical re-export, and nothing half-written."""

from __future__ import annotations

import hashlib
import json

import numpy as np
import pytest

from inpaintenv.data import ArrayDataset, SyntheticStreets, open_source, write_depth_png
from inpaintenv.submission import ManifestError, export, read_manifest, score


def tree(folder):
    """Relative path -> bytes of every file under ``folder``."""
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_manifest_lists_every_file_with_its_sha256(tmp_path, streets):
    m = export(tmp_path / "x", streets, "freeform-v1", [2, 0], progress=False, trusted=True)
    assert m.path == tmp_path / "x.key.json"  # the score key, beside the kit
    doc = json.loads(m.path.read_text())
    assert doc["protocol"]["name"] == "freeform-v1" and doc["protocol"]["version"] == "v1"
    assert doc["seeds"] == [2, 0] and doc["frame_shape"] == [64, 192]
    assert doc["ground_truth"]["type"] == "synthetic" and doc["ground_truth"]["seed"] == 0
    assert [f["frame_id"] for f in doc["frames"]] == list(streets.frame_ids)
    files = tree(tmp_path / "x")
    # The inputs and masks and the manifest, nothing else: no ground truth is exported.
    assert set(files) == {"manifest.json"} | {i.input for i in m.items} | {i.hole for i in m.items}
    assert len(m.items) == 2 * len(streets) and [i.seed for i in m.items[:2]] == [2, 2]  # seed-major
    for item in m.items:
        assert hashlib.sha256(files[item.input]).hexdigest() == item.input_sha256
        assert hashlib.sha256(files[item.hole]).hexdigest() == item.hole_sha256
        assert item.input.startswith(f"freeform-v1/seed_{item.seed}/synthetic/")
        assert "/proj_depth/velodyne_raw/image_02/" in item.input and "/proj_depth/hole/image_02/" in item.hole
    assert read_manifest(tmp_path / "x").items == m.items  # the kit lists the same files


def test_kitti_manifest_records_the_ground_truth_files(tmp_path, kitti_root):
    source = open_source(kitti_root, split="val")
    m = export(tmp_path / "x", source, "rect-v1", [0], progress=False)
    assert m.ground_truth["type"] == "kitti" and m.ground_truth["crop"] == [352, 1216]
    for frame, path in zip(m.frames, source.paths):
        assert frame.ground_truth == path.relative_to(kitti_root).as_posix()
        assert frame.ground_truth_sha256 == hashlib.sha256(path.read_bytes()).hexdigest()
    assert m.items[0].input.startswith("rect-v1/seed_0/val/2011_")
    assert str(kitti_root) not in m.path.read_text()  # the root may move between export and score
    assert str(tmp_path) not in m.path.read_text()  # the key names its kit relatively


def test_re_export_is_byte_identical(tmp_path, streets):
    export(tmp_path / "a", streets, "rect-v1", [0, 1], progress=False, trusted=True)
    export(tmp_path / "b", streets, "rect-v1", [0, 1], progress=False, trusted=True)
    first = tree(tmp_path / "a")
    assert tree(tmp_path / "b") == first
    key = (tmp_path / "a.key.json").read_bytes()
    assert (tmp_path / "b.key.json").read_bytes() == key.replace(b'"kit": "a"', b'"kit": "b"')
    export(tmp_path / "a", streets, "rect-v1", [0, 1], overwrite=True, progress=False, trusted=True)
    assert tree(tmp_path / "a") == first and (tmp_path / "a.key.json").read_bytes() == key


def test_out_folder_rules(tmp_path, streets):
    (tmp_path / "busy").mkdir()
    (tmp_path / "busy" / "notes.txt").write_text("mine")
    with pytest.raises(ValueError, match="not empty and holds no export"):
        export(tmp_path / "busy", streets, progress=False)
    assert tree(tmp_path / "busy") == {"notes.txt": b"mine"}
    export(tmp_path / "x", streets, n_frames=2, progress=False)
    with pytest.raises(ValueError, match="pass --overwrite"):
        export(tmp_path / "x", streets, n_frames=2, progress=False)
    (tmp_path / "x" / "mine.png").write_bytes(b"keep me")
    with pytest.raises(ValueError, match="mine.png"):
        export(tmp_path / "x", streets, n_frames=2, overwrite=True, progress=False)
    assert (tmp_path / "x" / "mine.png").read_bytes() == b"keep me"
    (tmp_path / "empty").mkdir()
    assert len(export(tmp_path / "empty", streets, n_frames=2, progress=False).frames) == 2


class FailsAtFrame(SyntheticStreets):
    def _load(self, index):
        if index == 3:
            raise OSError("disk gone")
        return super()._load(index)


def test_a_failed_export_leaves_nothing(tmp_path):
    with pytest.raises(OSError, match="disk gone"):
        export(tmp_path / "x", FailsAtFrame(n=8, frame_shape=(32, 48)), progress=False)
    assert list(tmp_path.iterdir()) == []


def test_depth_below_the_png_resolution_is_refused(tmp_path):
    frames = np.full((2, 32, 48), 5.0, np.float32)
    frames[1, 3, 4] = 0.001
    with pytest.raises(ValueError, match="frame 1 .* below 1/512 m"):
        export(tmp_path / "x", frames, progress=False)
    assert list(tmp_path.iterdir()) == []


def test_custom_dataset_is_scored_against_the_dataset_passed_in(tmp_path, streets):
    custom = ArrayDataset(np.stack([streets[i] for i in range(3)]))
    m = export(tmp_path / "x", custom, progress=False)
    assert m.ground_truth["type"] == "custom"
    (tmp_path / "p").mkdir()
    for item in m.items:
        write_depth_png(tmp_path / "p" / item.input, np.where(m.read_hole(item), 10.0, m.read_input(item)))
    with pytest.raises(ValueError, match="score it in Python with score"):
        score(m.path, tmp_path / "p")
    assert len(score(m.path, tmp_path / "p", source=custom).rows) == 3
    other = ArrayDataset(np.stack([streets[i] for i in range(3, 6)]))
    with pytest.raises(ManifestError, match="frame 0 .* differs"):
        score(m.path, tmp_path / "p", source=other)

