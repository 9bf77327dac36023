"""What a submitter gets and what ``score`` reads: no hidden truth in the kit, no file outside
the predictions folder, each prediction bound to its input, tampered score keys refused,
and ``export --overwrite`` deleting only what it wrote."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import sys

import cv2
import numpy as np
import pytest

from inpaintenv.cli import main
from inpaintenv.data import KittiDepth, write_depth_png
from inpaintenv.submission import ManifestError, SubmissionError, export, read_manifest, score

DATA = ["--n-frames", "16", "--frame-shape", "64", "192"]


def fill(manifest, predictions, value=10.0):
    """Predictions that keep every measured pixel and put ``value`` m in the holes."""
    for item in manifest.items:
        write_depth_png(predictions / item.input, np.where(manifest.read_hole(item), value, manifest.read_input(item)))


@pytest.fixture
def submitted(tmp_path, streets):
    """A one-seed export of four frames (the score key) and its predictions folder."""
    manifest = export(tmp_path / "inputs", streets, "rect-v1", [0], n_frames=4, progress=False)
    fill(manifest, tmp_path / "predictions")
    return manifest, tmp_path / "predictions"


# -- 2(a): one mask per frame ---------------------------------------------------------------

def raw_of(path):
    return cv2.imread(str(path), cv2.IMREAD_UNCHANGED)


@pytest.mark.parametrize("seeds", [[0], [3], [0, 1], [0, 1, 2]])
def test_no_pixel_a_hole_hides_is_measured_in_any_input_of_its_frame(tmp_path, streets, seeds):
    try:
        export(tmp_path / "x", streets, "rect-v1", seeds, n_frames=6, progress=False)
    except ValueError as exc:  # several seeds: refused, nothing written
        assert len(seeds) > 1 and "one mask per frame" in str(exc) and "--trusted" not in str(exc)
        assert list(tmp_path.iterdir()) == []
        return
    kit = read_manifest(tmp_path / "x")
    by_frame: dict[int, list] = {}
    for item in kit.items:
        by_frame.setdefault(item.index, []).append(item)
    for items in by_frame.values():
        hidden = np.any([raw_of(kit.root / i.hole) > 0 for i in items], axis=0)
        for item in items:
            assert not (raw_of(kit.root / item.input)[hidden]).any(), f"{item.input} shows a hidden pixel"


def test_trusted_exports_say_they_leak(tmp_path, streets, capsys):
    m = export(tmp_path / "x", streets, "rect-v1", [0, 1], n_frames=2, progress=False, trusted=True)
    assert m.trusted and read_manifest(tmp_path / "x").trusted
    first, second = (i for i in m.items if i.index == 0)
    # What the flag allows: seed 1's input measures pixels in seed 0's hole.
    assert (raw_of(m.root / second.input)[raw_of(m.root / first.hole) > 0] > 0).any()
    assert main(["export", *DATA, "--seed", "0", "--seed", "1", "--out", str(tmp_path / "cli"), "-q"]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "one mask per frame" in err and "--trusted" in err, err
    assert not (tmp_path / "cli").exists()
    assert main(["export", *DATA, "--seed", "0", "--seed", "1", "--trusted", "--out", str(tmp_path / "cli"),
                 "-q"]) == 0
    assert "do not give this export to a submitter" in capsys.readouterr().out


# -- 2(c): the kit holds no ground truth ----------------------------------------------------

def test_the_kit_holds_nothing_that_rebuilds_the_truth(tmp_path, streets):
    m = export(tmp_path / "x", streets, "rect-v1", [0], n_frames=4, progress=False)
    kit_text = (tmp_path / "x" / "manifest.json").read_text()
    kit = json.loads(kit_text)
    assert kit["role"] == "submission-kit" and "ground_truth" not in kit and "kit" not in kit
    assert all(set(f) == {"index", "frame_id", "drive"} for f in kit["frames"])
    for frame in m.frames:  # neither the frames' hashes nor their positions
        assert frame.ground_truth_sha256 not in kit_text
    assert '"frames_per_drive"' not in kit_text and '"position"' not in kit_text
    # The score key, kept by whoever scores, has them, outside the kit.
    key = json.loads((tmp_path / "x.key.json").read_text())
    assert key["role"] == "score-key" and key["ground_truth"]["type"] == "synthetic" and key["kit"] == "x"
    assert {p.name for p in tmp_path.iterdir()} == {"x", "x.key.json"}


def test_the_kit_manifest_cannot_be_scored(submitted, tmp_path, capsys):
    manifest, predictions = submitted
    with pytest.raises(ManifestError, match="holds no ground truth.*inputs.key.json"):
        score(manifest.root / "manifest.json", predictions)
    assert main(["score", "--manifest", str(manifest.root / "manifest.json"), "--predictions", str(predictions),
                 "--name", "x", "--out", str(tmp_path / "run"), "-q"]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "holds no ground truth" in err, err


def test_the_key_never_goes_into_the_kit(tmp_path, streets):
    with pytest.raises(ValueError, match="would lie in the export"):
        export(tmp_path / "x", streets, n_frames=2, progress=False, key=tmp_path / "x" / "key.json")
    m = export(tmp_path / "x", streets, n_frames=2, progress=False, key=tmp_path / "keys" / "k.json")
    assert m.path == tmp_path / "keys" / "k.json" and m.root == tmp_path / "x"
    fill(m, tmp_path / "p")
    assert len(score(m.path, tmp_path / "p").rows) == 2
    shutil.rmtree(tmp_path / "x")  # the kit was handed out: the key alone scores
    assert len(score(m.path, tmp_path / "p").rows) == 2


# -- 2(b): score reads only regular files inside its folder ---------------------------------

def first_prediction(manifest, predictions):
    return predictions / manifest.items[0].input


def test_a_link_to_a_file_outside_is_refused(submitted, tmp_path):
    manifest, predictions = submitted
    target = first_prediction(manifest, predictions)
    outside = tmp_path / "elsewhere.png"
    shutil.move(target, outside)  # a valid prediction, but outside the folder
    target.symlink_to(outside)
    with pytest.raises(SubmissionError, match=r"regular files inside .*0000000000\.png is a symbolic link"):
        score(manifest.path, predictions)
    target.unlink()
    target.symlink_to("/etc/passwd")
    with pytest.raises(SubmissionError, match="symbolic link"):
        score(manifest.path, predictions)


def test_a_linked_folder_is_refused(submitted, tmp_path):
    manifest, predictions = submitted
    shutil.move(predictions / "rect-v1", tmp_path / "real")
    (predictions / "rect-v1").symlink_to(tmp_path / "real")
    with pytest.raises(SubmissionError, match="rect-v1/ is a symbolic link"):
        score(manifest.path, predictions)


def test_a_huge_sparse_file_is_refused_unread(submitted):
    manifest, predictions = submitted
    target = first_prediction(manifest, predictions)
    with open(target, "r+b") as f:
        f.truncate(64 << 20)  # sparse: claims 64 MB, the frame's PNG needs at most ~1 MB
    with pytest.raises(SubmissionError, match=r"67,108,864 bytes, more than the"):
        score(manifest.path, predictions)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="FIFOs are POSIX")
def test_a_fifo_is_refused_not_waited_on(submitted):
    manifest, predictions = submitted
    target = first_prediction(manifest, predictions)
    target.unlink()
    os.mkfifo(target)
    with pytest.raises(SubmissionError, match=r"is a FIFO \(named pipe\), not a regular file"):
        score(manifest.path, predictions)


def test_a_hard_link_to_the_ground_truth_is_refused(tmp_path):
    """Without the crop (a selection of 352 x 1216 frames), a ground-truth file is a valid
    prediction that keeps every measured pixel: only its identity tells it apart."""
    root = tmp_path / "kitti"
    gt_file = root / "val" / "2011_09_26_drive_0002_sync" / "proj_depth" / "groundtruth" / "image_02" / "0000000000.png"
    gt_file.parent.mkdir(parents=True)
    raw = np.zeros((64, 192), np.uint16)
    raw[::3, ::2] = np.arange(1, 1 + raw[::3, ::2].size, dtype=np.uint16).reshape(raw[::3, ::2].shape) % 9000 + 300
    cv2.imwrite(str(gt_file), raw)
    source = KittiDepth(root, split="val", crop=None)
    m = export(tmp_path / "x", source, progress=False)
    target = tmp_path / "p" / m.items[0].input
    target.parent.mkdir(parents=True)
    os.link(gt_file, target)
    with pytest.raises(SubmissionError, match="is a ground-truth file"):
        score(m.path, tmp_path / "p", kitti_root=root, allow_unfilled=True)
    target.unlink()
    fill(m, tmp_path / "p")
    assert len(score(m.path, tmp_path / "p", kitti_root=root).rows) == 1


# -- 2(d): each prediction is bound to its input --------------------------------------------

def test_a_prediction_of_another_seed_is_named(tmp_path, streets):
    m = export(tmp_path / "x", streets, "rect-v1", [0, 1], n_frames=3, progress=False, trusted=True)
    fill(m, tmp_path / "p")
    seed0, seed1 = (i for i in m.items if i.index == 1)
    shutil.copy(tmp_path / "p" / seed1.input, tmp_path / "p" / seed0.input)
    with pytest.raises(SubmissionError) as info:
        score(m.path, tmp_path / "p")
    message = str(info.value)
    assert f"{seed0.input} does not keep" in message and f"it is the prediction of {seed1.input} (seed 1)" in message


def test_predictions_of_swapped_frames_are_refused(submitted):
    manifest, predictions = submitted
    a, b = (predictions / i.input for i in manifest.items[:2])
    data_a, data_b = a.read_bytes(), b.read_bytes()
    a.write_bytes(data_b)
    b.write_bytes(data_a)
    with pytest.raises(SubmissionError, match=r"2 predictions unusable: .* does not keep \d+ of its input's measured"):
        score(manifest.path, predictions)


# -- 12 / 1: tampered score keys --------------------------------------------------------------

def tamper(manifest, edit):
    doc = json.loads(manifest.path.read_text())
    edit(doc)
    manifest.path.write_text(json.dumps(doc))


@pytest.mark.parametrize("edit, message", [
    (lambda d: d["items"][0].update(index=999), r"items\[0\]\.index must be in 0\.\.3, got 999"),
    (lambda d: d["items"][0].update(index=-1), r"items\[0\]\.index must be in 0\.\.3, got -1"),
    (lambda d: d["items"][0].update(seed=7), r"items\[0\]\.seed is 7, which is not one of seeds \[0\]"),
    (lambda d: d["items"].pop(), r"items lack 1 of the 4 \(seed, frame\) pairs, first frame 3 seed 0"),
    (lambda d: d["items"].append(dict(d["items"][0])), r"items\[4\] lists frame 0 seed 0 a second time"),
    (lambda d: d.update(seeds=[0.0]), r"seeds must be an integer, got 0\.0"),
    (lambda d: d.update(seeds=[False]), r"seeds must be an integer, got False"),
    (lambda d: d["items"][0].update(seed=0.5), r"items\[0\]\.seed must be an integer, got 0\.5"),
    (lambda d: d.update(frame_shape="352x1216"), r"frame_shape must be a list of two integers \[H, W\], got '352x1216'"),
    (lambda d: d.update(frame_shape=[10**6, 10**6]), r"frame_shape declares 1000000x1000000 = 1,000,000,000,000 pixels"),
    (lambda d: d.update(frame_shape=[40000, 40000]), r"frame_shape declares 40000x40000 = 1,600,000,000 pixels"),
    (lambda d: d["ground_truth"].update(n=10**12), r"ground_truth\.n must be an integer in 1\.\.1,000,000"),
    (lambda d: d["items"][0].update(input="../../outside.png"), r"items\[0\]\.input must be a distinct \.png path"),
])
def test_tampered_keys_are_one_clear_error(submitted, edit, message):
    manifest, predictions = submitted
    tamper(manifest, edit)
    with pytest.raises(ManifestError, match=message):
        score(manifest.path, predictions)


def as_kitti(manifest, root, paths):
    """Turn a synthetic score key into a KITTI one whose frames are ``paths`` (relative to ``root``)."""
    def edit(doc):
        doc["ground_truth"] = {"type": "kitti", "kind": "groundtruth", "crop": None, "hash": "sha256 of the file"}
        for frame, path in zip(doc["frames"], paths):
            frame.pop("position")
            frame["ground_truth"] = path
    tamper(manifest, edit)


def test_a_huge_crop_is_refused(submitted, tmp_path):
    manifest, predictions = submitted
    as_kitti(manifest, tmp_path, ["a.png"] * 4)
    tamper(manifest, lambda d: d["ground_truth"].update(crop=[100000, 100000]))
    with pytest.raises(ManifestError, match=r"ground_truth\.crop declares 100000x100000 = 10,000,000,000 pixels"):
        score(manifest.path, predictions, kitti_root=tmp_path)


@pytest.mark.parametrize("how", ["dotdot", "absolute", "link"])
def test_ground_truth_outside_the_root_is_refused_without_its_hash(submitted, tmp_path, how):
    manifest, predictions = submitted
    root = tmp_path / "kitti"
    root.mkdir()
    secret = tmp_path / "secret.png"
    cv2.imwrite(str(secret), np.full((64, 192), 2560, np.uint16))
    digest = hashlib.sha256(secret.read_bytes()).hexdigest()
    if how == "link":
        (root / "gt.png").symlink_to(secret)
    path = {"dotdot": "../secret.png", "absolute": str(secret), "link": "gt.png"}[how]
    as_kitti(manifest, root, [path] * 4)
    with pytest.raises(ManifestError) as info:
        score(manifest.path, predictions, kitti_root=root)
    message = str(info.value)
    assert ("outside the KITTI root" in message) or ("relative to the KITTI root, without '..'" in message), message
    assert digest[:6] not in message


# -- 4: export --overwrite deletes only what it wrote; leftovers ------------------------------

def test_overwrite_never_deletes_a_file_an_edited_manifest_lists(tmp_path, streets):
    m = export(tmp_path / "x", streets, n_frames=2, progress=False)
    mine = tmp_path / "x" / "rect-v1" / "seed_0" / "mine.png"
    mine.write_bytes(b"keep me")
    kit = tmp_path / "x" / "manifest.json"
    doc = json.loads(kit.read_text())
    doc["items"][0]["input"] = "rect-v1/seed_0/mine.png"
    kit.write_text(json.dumps(doc))
    with pytest.raises(ValueError, match=r"did not write, or changed since \(.*mine\.png"):
        export(tmp_path / "x", streets, n_frames=2, overwrite=True, progress=False)
    assert mine.read_bytes() == b"keep me"
    # An exported input changed by hand is not replaced either.
    doc["items"][0]["input"] = m.items[0].input
    kit.write_text(json.dumps(doc))
    mine.unlink()
    write_depth_png(tmp_path / "x" / m.items[0].input, np.ones(m.frame_shape))
    with pytest.raises(ValueError, match="did not write, or changed since"):
        export(tmp_path / "x", streets, n_frames=2, overwrite=True, progress=False)


def dead_pid() -> int:
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


def test_a_later_export_removes_what_a_killed_one_left(tmp_path, streets):
    stale = tmp_path / f".x.partial-{dead_pid()}"
    (stale / "rect-v1").mkdir(parents=True)
    (stale / "rect-v1" / "big.png").write_bytes(b"0" * 1000)
    stale_key = tmp_path / f".x.key.json.partial-{dead_pid()}"
    stale_key.write_text("{}")
    alive = tmp_path / f".x.partial-{os.getppid()}"  # a running export's: kept
    alive.mkdir()
    other = tmp_path / ".y.partial-1"  # another export's
    other.mkdir()
    export(tmp_path / "x", streets, n_frames=2, progress=False)
    assert not stale.exists() and not stale_key.exists() and alive.is_dir() and other.is_dir()


def test_a_partial_name_whose_pid_does_not_parse_is_left_alone(tmp_path, streets):
    """``.<out>.partial-<23 digits>`` beside --out crashed export with an OverflowError."""
    odd = [tmp_path / f".x.partial-{'1' * 23}", tmp_path / ".x.partial-\u00b2", tmp_path / f".x.replaced-{'9' * 30}-ab",
           tmp_path / f".x.key.json.partial-{'7' * 23}"]
    for folder in odd:
        folder.mkdir()
    export(tmp_path / "x", streets, n_frames=2, progress=False)
    assert all(folder.is_dir() for folder in odd) and (tmp_path / "x" / "manifest.json").is_file()


def test_overwrite_into_a_linked_folder(tmp_path, capsys):
    (tmp_path / "real").mkdir()
    (tmp_path / "link").symlink_to(tmp_path / "real")
    argv = ["export", *DATA, "--out", str(tmp_path / "link"), "-q"]
    assert main(argv) == 0
    assert main([*argv, "--overwrite"]) == 0, capsys.readouterr().err
    assert (tmp_path / "link").is_symlink() and (tmp_path / "real" / "manifest.json").is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link", "link.key.json", "real"]
    assert read_manifest(tmp_path / "link.key.json").root.resolve() == (tmp_path / "real").resolve()


# -- names that score passed over or printed alike, a key's kit elsewhere, a read-only --out -----

def test_an_upper_case_png_is_listed_as_unexpected(submitted):
    manifest, predictions = submitted
    first = first_prediction(manifest, predictions)
    shutil.copy(first, first.with_name("0000000099.PNG"))  # was passed over in silence
    with pytest.raises(SubmissionError, match=r"1 PNG file there is not a prediction.*0000000099\.PNG"):
        score(manifest.path, predictions)


def test_nfc_and_nfd_twins_read_apart(submitted):
    manifest, predictions = submitted
    first = first_prediction(manifest, predictions)
    nfc, nfd = "caf\u00e9.png", "cafe\u0301.png"  # one name to the eye
    shutil.copy(first, first.with_name(nfc))
    shutil.copy(first, first.with_name(nfd))
    with pytest.raises(SubmissionError) as info:
        score(manifest.path, predictions)
    message = str(info.value)
    assert "2 PNG files there are not predictions" in message
    assert "caf\\xe9.png]" in message and "cafe\\u0301.png]" in message, message


@pytest.mark.parametrize("kit, says", [
    ("/etc", "normalised relative path"),
    ("inputs/../../../etc", "normalised relative path"),
    ("./inputs", "normalised relative path"),
    ("../../../../../../../../etc", "holds no export"),
    ("predictions", "holds no export"),
])
def test_a_keys_kit_must_name_this_export(submitted, tmp_path, kit, says):
    manifest, predictions = submitted
    doc = json.loads(manifest.path.read_text())
    doc["kit"] = kit
    bad = tmp_path / "bad.key.json"
    bad.write_text(json.dumps(doc))
    with pytest.raises(ManifestError, match=says):
        score(bad, predictions)


def test_a_key_kept_elsewhere_still_names_its_kit(tmp_path, streets):
    m = export(tmp_path / "x", streets, n_frames=2, progress=False, key=tmp_path / "keys" / "deep" / "k.json")
    assert json.loads(m.path.read_text())["kit"] == "../../x"
    assert read_manifest(m.path).root == tmp_path / "x"
    other = export(tmp_path / "y", streets, n_frames=3, progress=False)
    doc = json.loads(m.path.read_text())
    doc["kit"] = "../../y"  # another export's kit
    (tmp_path / "keys" / "deep" / "k.json").write_text(json.dumps(doc))
    with pytest.raises(ManifestError, match="holds another export"):
        read_manifest(m.path)
    assert other.root == tmp_path / "y"


def test_a_read_only_out_is_one_line_naming_the_folder(submitted, tmp_path, capsys, monkeypatch):
    manifest, predictions = submitted
    ro = tmp_path / "ro"
    ro.mkdir()
    real = os.access
    # A read-only disk as os.access sees it (a test cannot mount one; root may write through chmod).
    monkeypatch.setattr(os, "access", lambda p, mode, **kw: False if os.fspath(p) == str(ro) else real(p, mode, **kw))
    status = main(["score", "--manifest", str(manifest.path), "--predictions", str(predictions), "--name", "x",
                   "--figure-frames", "0", "--out", str(ro / "run"), "-q"])
    err = capsys.readouterr().err.strip()
    assert status == 1 and len(err.splitlines()) == 1, err
    assert f"--out {ro / 'run'}: cannot write the run folder there ({ro} is on a read-only disk" in err
    assert list(ro.iterdir()) == []


def test_export_never_writes_into_the_data_root_it_reads(tmp_path, capsys):
    """A kit or key inside --kitti-root was written there (next to the ground truth it reads)."""
    drive = tmp_path / "kitti" / "train" / "2011_09_26_drive_0001_sync" / "proj_depth" / "groundtruth" / "image_02"
    rows = np.linspace(40.0, 5.0, 376)[:, None] + np.zeros((1, 1241))
    write_depth_png(drive / "0000000000.png", np.where(np.random.default_rng(0).random(rows.shape) < 0.3, rows, 0.0))
    root = tmp_path / "kitti"
    before = sorted(p.relative_to(root) for p in root.rglob("*"))
    for more in (["--out", str(root / "train" / "kit")], ["--out", str(tmp_path / "kit"), "--key", str(root / "k.json")]):
        assert main(["export", "--kitti-root", str(root), "--holdout", "0", *more, "-q"]) == 1
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and f"inside the data root {root}" in err, err
    assert sorted(p.relative_to(root) for p in root.rglob("*")) == before
    assert main(["export", "--kitti-root", str(root), "--holdout", "0", "--out", str(tmp_path / "kit"), "-q"]) == 0
