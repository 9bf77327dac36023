"""Exports of scans: the input is each frame's single LiDAR scan with the hole cut out, the
ground truth only the target. export -> a separate process -> score equals evaluate(); the
score key records how to rebuild the scans and refuses a tampered one in one line."""

from __future__ import annotations

import hashlib
import json
import math
import os

import cv2
import numpy as np
import pytest

from inpaintenv.cli import main
from inpaintenv.data import KittiDepth, SyntheticStreets, write_depth_png
from inpaintenv.evaluate import evaluate
from inpaintenv.report.results import ID_COLUMNS, METRIC_COLUMNS
from inpaintenv.exceptions import InvalidInputError, UnsafeFileError
from inpaintenv.submission import ManifestError, SubmissionError, export, read_manifest, score

PROTOCOLS = ("densify-v1", "rect-v1")
COMPARED = tuple(c for c in ID_COLUMNS if c != "method") + ("hole_fraction",) + METRIC_COLUMNS
#: sha256 of the decoded uint16 inputs (frames in order) of a scan export of the built-in synthetic
#: streets of :func:`scans`: the pixel values, not the PNG bytes, which depend on the zlib build.
#: A failure means an export of scans (or the scans it is made from) changed: restore the old
#: behaviour; do not update the hash.
GOLDEN = {
    "densify-v1": "fffdda300dbeec99a055e1ed73ab1f643751727f42b208b13203fb128f90462c",
    "rect-v1": "0d2b71dc6b344c7b42df49f44ad365e9d83ab540c2762fb7e4f39bf6b7a75752",
}


@pytest.fixture(scope="module")
def scans() -> SyntheticStreets:
    """Eight small synthetic frames over two drives, each with its single scan as the input."""
    return SyntheticStreets(n=8, seed=0, frame_shape=(64, 192), frames_per_drive=4, input="scan")


def raw_of(path) -> np.ndarray:
    return cv2.imread(str(path), cv2.IMREAD_UNCHANGED)


def assert_close_rows(scored, reference, kind="scan") -> None:
    """Every identifying column equal and every metric within 1e-6 relative (NaN equal to NaN)."""
    key = lambda r: (r["seed"], r["index"])
    a, b = sorted(scored.rows, key=key), sorted(reference.rows, key=key)
    assert [key(r) for r in a] == [key(r) for r in b] and a
    for ra, rb in zip(a, b):
        assert ra["input_kind"] == rb["input_kind"] == kind
        for c in COMPARED:
            x, y = ra[c], rb[c]
            if isinstance(x, float) and isinstance(y, float):
                assert (math.isnan(x) and math.isnan(y)) or x == pytest.approx(y, rel=1e-6, abs=0), \
                    f"{c} of frame {ra['index']}: {x!r} through files, {y!r} in-process"
            else:
                assert x == y, f"{c} of frame {ra['index']}: {x!r} through files, {y!r} in-process"


def round_trip(tmp_path, source, protocol, run_fill, fill_method, kitti_root=None):
    """Export, fill in a separate process (docs/examples/fill_holes.py), score; and evaluate() in-process."""
    manifest = export(tmp_path / "inputs", source, protocol, [0], progress=False)
    run_fill(tmp_path / "inputs", tmp_path / "predictions")
    scored = score(manifest.path, tmp_path / "predictions", name="telea-script", kitti_root=kitti_root)
    reference = evaluate(fill_method, source, protocol, [0], progress=False, name="telea-script")
    return manifest, scored, reference


@pytest.mark.parametrize("protocol", PROTOCOLS)
def test_the_input_is_the_scan_with_the_hole_cut(tmp_path, scans, protocol):
    m = export(tmp_path / "x", scans, protocol, [0], progress=False)
    assert m.input_kind == "scan" and m.ground_truth["input"] == "scan"
    for item in m.items:
        scan, gt = (a[0] for a in scans.load_pairs([item.index]))
        hole = m.read_hole(item)
        raw = raw_of(m.root / item.input)
        np.testing.assert_array_equal(raw, np.rint(np.where(hole, 0.0, scan.astype(np.float64)) * 256))
        assert (raw == 0).sum() > (np.rint(gt * 256) == 0).sum()  # the scan, not the ground truth
        assert m.frames[item.index].scan_sha256 == hashlib.sha256(scan.tobytes()).hexdigest()
        assert hole.any() == (protocol != "densify-v1")
    kit = json.loads((tmp_path / "x" / "manifest.json").read_text())
    assert kit["input_kind"] == "scan" and "ground_truth" not in kit
    assert all(set(f) == {"index", "frame_id", "drive"} for f in kit["frames"])  # no truth, no scan hashes


@pytest.mark.parametrize("protocol", PROTOCOLS)
def test_golden_inputs_of_the_scan_protocols(tmp_path, scans, protocol):
    m = export(tmp_path / "x", scans, protocol, [0], progress=False)
    h = hashlib.sha256()
    for item in m.items:
        h.update(np.ascontiguousarray(raw_of(m.root / item.input), dtype="<u2").tobytes())
    assert h.hexdigest() == GOLDEN[protocol]


@pytest.mark.parametrize("protocol", PROTOCOLS)
def test_synthetic_scan_round_trip_equals_evaluate(tmp_path, scans, protocol, run_fill, fill_method):
    manifest, scored, reference = round_trip(tmp_path, scans, protocol, run_fill, fill_method)
    assert_close_rows(scored, reference)
    assert len(scored.rows) == len(manifest.items)
    assert all(r["unmeasured_count"] > r["hole_count"] for r in scored.rows)


@pytest.mark.parametrize("kind, protocol", [("scan-rings16-v1", "rect-v1"), ("scan-points25-v1", "densify-v1")])
def test_a_density_variant_round_trip_equals_evaluate(tmp_path, kind, protocol, run_fill, fill_method):
    """A thinned scan exported, filled in a separate process and scored: the scores of evaluate() in-process."""
    source = SyntheticStreets(n=4, seed=0, frame_shape=(64, 192), frames_per_drive=2, input=kind)
    manifest, scored, reference = round_trip(tmp_path, source, protocol, run_fill, fill_method)
    assert manifest.input_kind == kind and manifest.ground_truth["input"] == kind
    assert_close_rows(scored, reference, kind)
    for item in manifest.items:  # the input written is the thinned scan with the hole cut
        scan = source.input_frame(item.index)
        np.testing.assert_array_equal(raw_of(manifest.root / item.input),
                                      np.rint(np.where(manifest.read_hole(item), 0.0, scan.astype(np.float64)) * 256))


@pytest.mark.kitti
def test_kitti_ring_thinned_round_trip_equals_evaluate(tmp_path, kitti_root, run_fill, fill_method):
    """The score key lists the full scan file; scoring thins it again from the day's calibration under the root."""
    source = KittiDepth(kitti_root, split="val_selection", input="scan-rings8-v1")
    manifest, scored, reference = round_trip(tmp_path, source, "rect-v1", run_fill, fill_method, kitti_root)
    assert_close_rows(scored, reference, "scan-rings8-v1")
    full = KittiDepth(kitti_root, split="val_selection", input="scan")
    for item in manifest.items:
        thinned, scan = source.input_frame(item.index), full.input_frame(item.index)
        assert 0 < np.count_nonzero(thinned) < 0.2 * np.count_nonzero(scan)
        np.testing.assert_array_equal(raw_of(manifest.root / item.input).astype(np.float32) / 256,
                                      np.where(manifest.read_hole(item), 0, thinned))


@pytest.mark.kitti
@pytest.mark.parametrize("protocol", PROTOCOLS)
def test_kitti_val_selection_scan_round_trip_equals_evaluate(tmp_path, kitti_root, protocol, run_fill, fill_method):
    source = KittiDepth(kitti_root, split="val_selection", input="scan")  # the official frames with a scan
    manifest, scored, reference = round_trip(tmp_path, source, protocol, run_fill, fill_method, kitti_root)
    assert_close_rows(scored, reference)
    for frame, gt_path, scan_path in zip(manifest.frames, source.paths, source.input_paths):
        assert frame.ground_truth == gt_path.relative_to(kitti_root).as_posix()
        assert frame.scan == scan_path.relative_to(kitti_root).as_posix()
        assert frame.scan_sha256 == hashlib.sha256(scan_path.read_bytes()).hexdigest()
    for item in manifest.items:  # KITTI scans are on the 1/256 m grid: exported exactly
        scan = source.input_frame(item.index)
        np.testing.assert_array_equal(raw_of(manifest.root / item.input).astype(np.float32) / 256,
                                      np.where(manifest.read_hole(item), 0, scan))
    assert str(kitti_root) not in manifest.path.read_text()


def test_a_prediction_must_keep_the_scan_and_fill_what_it_did_not_measure(tmp_path, scans):
    m = export(tmp_path / "x", scans, "rect-v1", [0], n_frames=2, progress=False)
    for item in m.items:
        depth = m.read_input(item)
        write_depth_png(tmp_path / "p" / item.input, np.where(depth > 0, depth, 7.0))
    assert len(score(m.path, tmp_path / "p").rows) == 2
    first = m.items[0]
    depth = m.read_input(first)
    changed = np.where(depth > 0, depth + 1, 7.0)
    write_depth_png(tmp_path / "p" / first.input, changed)
    with pytest.raises(SubmissionError, match="does not keep .* of its input's measured pixels"):
        score(m.path, tmp_path / "p")
    write_depth_png(tmp_path / "p" / first.input, np.where(depth > 0, depth, 0.0))  # only the scan, nothing filled
    with pytest.raises(SubmissionError, match="unmeasured pixels with ground truth left at 0"):
        score(m.path, tmp_path / "p")
    assert len(score(m.path, tmp_path / "p", allow_unfilled=True).rows) == 2


def test_densify_needs_scans_and_a_map_export_keeps_its_key(tmp_path, scans):
    maps = SyntheticStreets(n=2, frame_shape=(64, 192))
    with pytest.raises(InvalidInputError, match="densify-v1 .* a map input has nothing to fill"):
        export(tmp_path / "x", maps, "densify-v1", progress=False)
    m = export(tmp_path / "x", maps, "rect-v1", progress=False)
    doc = json.loads(m.path.read_text())
    assert "input_kind" not in doc and "input" not in doc["ground_truth"] and m.input_kind == "map"
    assert all("scan_sha256" not in f for f in doc["frames"])
    other = SyntheticStreets(n=2, frame_shape=(64, 192), input="scan")
    with pytest.raises(ManifestError, match="input kind 'scan'"):
        score(m.path, tmp_path / "p", source=other)


def test_cli_export_and_score_of_scans(tmp_path, capsys, run_fill):
    data = ["--n-frames", "8", "--frame-shape", "64", "192", "--holdout", "0"]
    assert main(["export", *data, "--input", "scan", "--protocol", "densify-v1", "--out", str(tmp_path / "in"),
                 "-q"]) == 0
    assert "inputs: scans" in capsys.readouterr().out
    run_fill(tmp_path / "in", tmp_path / "pred")
    assert main(["score", "--manifest", str(tmp_path / "in.key.json"), "--predictions", str(tmp_path / "pred"),
                 "--name", "telea-script", "-m", "harmonic", "--out", str(tmp_path / "run"), "-q"]) == 0
    out = capsys.readouterr().out
    assert "scan" in out and "densify-v1" in out and "telea-script" in out and "harmonic" in out
    rows = json.loads((tmp_path / "run" / "results.json").read_text())["rows"]
    assert {r["input_kind"] for r in rows} == {"scan"} and all("kitti_rmse" in r for r in rows)
    assert not (tmp_path / "run" / "figures").exists()  # panels draw map inputs only


# -- a tampered key of scans ------------------------------------------------------------------

def fake_kitti(root, n=2):
    """A KITTI tree of ``n`` frames with ground truth and scans (32x64, uncropped)."""
    rng = np.random.default_rng(0)
    for k in range(n):
        base = root / "val" / "2011_09_26_drive_0002_sync" / "proj_depth"
        truth = np.where(rng.random((32, 64)) < 0.5, 12.0 + k, 0.0)
        write_depth_png(base / "groundtruth" / "image_02" / f"{k:010d}.png", truth)
        write_depth_png(base / "velodyne_raw" / "image_02" / f"{k:010d}.png",
                        np.where(rng.random((32, 64)) < 0.1, truth, 0.0))
    return KittiDepth(root, split="val", crop=None, input="scan")


@pytest.fixture
def kitti_scans(tmp_path):
    """A KITTI export of scans with filled predictions: (key path, predictions, KITTI root)."""
    source = fake_kitti(tmp_path / "kitti")
    m = export(tmp_path / "x", source, "rect-v1", [0], progress=False)
    for item in m.items:
        depth = m.read_input(item)
        write_depth_png(tmp_path / "p" / item.input, np.where(depth > 0, depth, 10.0))
    assert len(score(m.path, tmp_path / "p", kitti_root=tmp_path / "kitti").rows) == 2
    return m.path, tmp_path / "p", tmp_path / "kitti"


def tamper(key, change) -> None:
    doc = json.loads(key.read_text())
    change(doc)
    key.write_text(json.dumps(doc))


def one_line(exc_info) -> str:
    text = str(exc_info.value)
    assert "\n" not in text and len(text) < 600, text
    return text


@pytest.mark.parametrize("path", ["../outside.png", "/etc/passwd", "val/../../outside.png"])
def test_a_scan_path_outside_the_root_is_refused_unread(kitti_scans, path):
    key, predictions, root = kitti_scans
    write_depth_png(root.parent / "outside.png", np.ones((32, 64)))
    tamper(key, lambda d: d["frames"][0].update(scan=path))
    with pytest.raises(ManifestError) as caught:
        score(key, predictions, kitti_root=root)
    assert "scan" in one_line(caught)


def test_a_scan_linked_out_of_the_root_is_refused_unread(kitti_scans):
    key, predictions, root = kitti_scans
    write_depth_png(root.parent / "outside.png", np.ones((32, 64)))
    link = root / "val" / "link.png"
    os.symlink(root.parent / "outside.png", link)
    tamper(key, lambda d: d["frames"][0].update(scan="val/link.png"))
    with pytest.raises(ManifestError, match="leads outside the KITTI root") as caught:
        score(key, predictions, kitti_root=root)
    assert "sha256" not in one_line(caught)  # nothing of the file, not even its hash


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="FIFOs are POSIX")
def test_a_scan_fifo_is_refused_at_once(kitti_scans):
    key, predictions, root = kitti_scans
    scan = root / json.loads(key.read_text())["frames"][1]["scan"]
    scan.unlink()
    os.mkfifo(scan)
    with pytest.raises(UnsafeFileError, match="scan file .* FIFO") as caught:
        score(key, predictions, kitti_root=root)
    one_line(caught)


@pytest.mark.parametrize("change, field", [
    (lambda d: d["frames"][0].update(scan_sha256="0" * 63), "scan_sha256"),
    (lambda d: d["frames"][0].pop("scan"), "scan"),
    (lambda d: d["frames"][0].update(scan={"a": [1]}), "scan"),
    (lambda d: d["ground_truth"].update(input="map"), "ground_truth.input"),
    (lambda d: d.update(input_kind="lidar"), "input_kind"),
])
def test_a_bad_scan_field_is_one_line_naming_it(kitti_scans, change, field):
    key, predictions, root = kitti_scans
    tamper(key, change)
    with pytest.raises(ManifestError) as caught:
        score(key, predictions, kitti_root=root)
    assert field in one_line(caught)


def test_a_changed_scan_and_nested_json_are_one_line(kitti_scans):
    key, predictions, root = kitti_scans
    scan = root / json.loads(key.read_text())["frames"][0]["scan"]
    write_depth_png(scan, np.full((32, 64), 3.0))
    with pytest.raises(ManifestError, match="is not the file .* was exported from") as caught:
        score(key, predictions, kitti_root=root)
    one_line(caught)
    key.write_text('{"frames": ' + "[" * 100_000 + "]" * 100_000 + "}")
    with pytest.raises(ManifestError) as caught:
        score(key, predictions, kitti_root=root)
    one_line(caught)


def test_a_scan_field_in_a_kit_or_a_map_key_is_refused(tmp_path, kitti_scans):
    key, _, _ = kitti_scans
    kit = read_manifest(key).root / "manifest.json"
    doc = json.loads(kit.read_text())
    doc["frames"][0]["scan_sha256"] = "0" * 64
    kit.write_text(json.dumps(doc))
    with pytest.raises(ManifestError, match="unknown fields"):
        read_manifest(kit)
    maps = export(tmp_path / "m", SyntheticStreets(n=2, frame_shape=(32, 48)), progress=False)
    tamper(maps.path, lambda d: d["frames"][0].update(scan_sha256="0" * 64))
    with pytest.raises(ManifestError, match="unknown fields"):
        read_manifest(maps.path)

