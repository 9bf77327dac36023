"""Interval files beside a submission's predictions (<name>_low/_high.png or <name>_std.png)."""

from __future__ import annotations

import os
from pathlib import Path
from statistics import NormalDist

import cv2
import numpy as np
import pytest

from inpaintenv.data import write_depth_png
from inpaintenv.exceptions import SubmissionError
from inpaintenv.metrics import INTERVAL_COLUMNS
from inpaintenv.submission import export, score
from inpaintenv.submission.intervals import sidecar


@pytest.fixture
def notebook(tmp_path, streets):
    """Four exported frames × two seeds and median-filled predictions; ``write(suffix, fn)`` adds interval files."""
    manifest = export(tmp_path / "inputs", streets, "rect-v1", [0, 1], n_frames=4, progress=False, trusted=True)
    folder = tmp_path / "predictions"
    preds = {}
    for item in manifest.items:
        depth, hole = manifest.read_input(item), manifest.read_hole(item)
        preds[item.input] = np.where(hole, np.median(depth[depth > 0]), depth).astype(np.float32)
        write_depth_png(folder / item.input, preds[item.input])

    def write(suffix, make, items=None):
        for item in items or manifest.items:
            write_depth_png(folder / sidecar(item.input, suffix), make(preds[item.input]))

    return manifest, folder, write


def _pred(folder: Path, rel: str) -> np.ndarray:
    return cv2.imread(str(folder / rel), cv2.IMREAD_UNCHANGED).astype(np.float64) / 256


def test_low_high_files_are_scored_and_equal_a_numpy_recomputation(notebook, streets):
    manifest, folder, write = notebook
    write("_low", lambda p: np.maximum(p - 3.0, 0))
    write("_high", lambda p: p + 3.0)
    result = score(manifest, folder, name="median")
    assert result.meta["submission"]["intervals"] == "bounds"
    gt_all = streets.load_batch(list(range(4)))
    items = {(it.seed, it.index): it for it in manifest.items}
    for row in result.rows:
        item = items[(row["seed"], row["index"])]
        gt, hole = gt_all[row["index"]], manifest.read_hole(item)
        low, high = _pred(folder, sidecar(item.input, "_low")), _pred(folder, sidecar(item.input, "_high"))
        inside, width = [], []
        for y, x in zip(*np.nonzero(hole & (gt > 0))):
            inside.append(low[y, x] <= gt[y, x] <= high[y, x])
            width.append(high[y, x] - low[y, x])
        assert row["hole_coverage"] == pytest.approx(np.mean(inside), abs=1e-12)
        assert row["hole_interval_width"] == pytest.approx(np.mean(width), rel=1e-9)
        assert set(INTERVAL_COLUMNS) <= set(row)


def test_std_file_gives_the_normal_interval_of_the_coverage(notebook):
    manifest, folder, write = notebook
    write("_std", lambda p: np.full_like(p, 0.5))
    wide = score(manifest, folder, name="median", interval_coverage=0.9).rows
    narrow = score(manifest, folder, name="median", interval_coverage=0.5).rows
    z9, z5 = NormalDist().inv_cdf(0.95), NormalDist().inv_cdf(0.75)
    assert wide[0]["hole_interval_width"] == pytest.approx(2 * z9 * 0.5, rel=1e-6)
    assert narrow[0]["hole_interval_width"] == pytest.approx(2 * z5 * 0.5, rel=1e-6)


def test_a_folder_without_interval_files_scores_as_before(notebook):
    manifest, folder, _ = notebook
    result = score(manifest, folder, name="median")
    assert not set(INTERVAL_COLUMNS) & set(result.rows[0])
    assert "intervals" not in result.meta["submission"] and "interval_coverage" not in result.meta


def test_interval_files_change_the_identity(notebook):
    manifest, folder, write = notebook
    before = score(manifest, folder, name="median").meta["submission"]["identity"]
    write("_std", lambda p: np.full_like(p, 0.5))
    assert score(manifest, folder, name="median").meta["submission"]["identity"] != before


@pytest.mark.parametrize(
    ("files", "message"),
    [
        ({"_low": lambda p: p}, "an interval is .*_low.png and .*_high.png"),
        ({"_low": lambda p: p, "_high": lambda p: p, "_std": lambda p: p}, "an interval is"),
        ({"_low": lambda p: p + 1, "_high": lambda p: p + 2}, "does not hold the prediction"),
        ({"_low": lambda p: p + 1, "_high": lambda p: np.maximum(p - 1, 0)}, "inverted"),
    ],
)
def test_bad_interval_files_are_one_error(notebook, files, message):
    manifest, folder, write = notebook
    for suffix, make in files.items():
        write(suffix, make)
    with pytest.raises(SubmissionError, match=message):
        score(manifest, folder, name="median")


def test_intervals_beside_some_predictions_only_are_refused(notebook):
    manifest, folder, write = notebook
    write("_std", lambda p: np.full_like(p, 1.0), items=manifest.items[:3])
    with pytest.raises(SubmissionError, match=r"all or none.*3 with std files.*with no interval"):
        score(manifest, folder, name="median")


def test_mixed_kinds_are_refused(notebook):
    manifest, folder, write = notebook
    write("_std", lambda p: np.full_like(p, 1.0), items=manifest.items[:2])
    write("_low", lambda p: p, items=manifest.items[2:])
    write("_high", lambda p: p, items=manifest.items[2:])
    with pytest.raises(SubmissionError, match="all or none, of one kind"):
        score(manifest, folder, name="median")


def test_an_8_bit_interval_file_is_unusable(notebook):
    manifest, folder, write = notebook
    write("_std", lambda p: np.full_like(p, 1.0))
    bad = folder / sidecar(manifest.items[0].input, "_std")
    cv2.imwrite(str(bad), np.zeros((64, 192), np.uint8))
    with pytest.raises(SubmissionError, match="_std.png is 8-bit"):
        score(manifest, folder, name="median")


@pytest.mark.skipif(os.name == "nt", reason="symbolic links")
def test_a_linked_interval_file_is_refused(notebook, tmp_path):
    manifest, folder, write = notebook
    write("_std", lambda p: np.full_like(p, 1.0))
    link = folder / sidecar(manifest.items[0].input, "_std")
    outside = tmp_path / "elsewhere.png"
    link.rename(outside)
    link.symlink_to(outside)
    with pytest.raises(SubmissionError, match="symbolic link"):
        score(manifest, folder, name="median")


def test_cli_score_reads_the_interval_files(notebook, tmp_path):
    from inpaintenv.cli import main

    manifest, folder, write = notebook
    write("_low", lambda p: np.maximum(p - 3.0, 0))
    write("_high", lambda p: p + 3.0)
    key = tmp_path / "inputs.key.json"
    assert key.is_file()
    out = tmp_path / "run"
    assert main(["score", "--manifest", str(key), "--predictions", str(folder), "--name", "median",
                 "--out", str(out), "--figure-frames", "1", "-q"]) == 0
    assert "hole coverage" in (out / "results.md").read_text()
    assert (out / "figures" / "error_rejection.png").is_file()
