"""``inpaintenv export`` / ``inpaintenv score`` from the command line: the run folder and report
of a benchmark, resuming, --on-missing, and one line for every bad submission."""

from __future__ import annotations

import json
import shutil

import cv2
import numpy as np
import pytest

from inpaintenv.cli import main
from inpaintenv.evaluate import evaluate
from inpaintenv.report.results import METRIC_COLUMNS
from inpaintenv.submission import read_manifest
from inpaintenv.submission.truth import open_truth

pytest.importorskip("estimators.classical")

DATA = ["--n-frames", "16", "--frame-shape", "64", "192"]


@pytest.fixture(scope="module")
def exported(tmp_path_factory, fill_script):
    """An export of the synthetic default's test split and the example method's predictions."""
    tmp = tmp_path_factory.mktemp("score")
    assert main(["export", *DATA, "--seed", "0", "--seed", "1", "--trusted", "--out", str(tmp / "inputs"), "-q"]) == 0
    fill_script["main"](tmp / "inputs", tmp / "predictions")
    return tmp


def score_argv(tmp, predictions, out, *extra, manifest="inputs"):
    return ["score", "--manifest", str(tmp / f"{manifest}.key.json"), "--predictions", str(predictions),
            "--name", "telea-script", "--out", str(out), "--figure-frames", "0", "-q", *extra]


def rows_by_method(out):
    doc = json.loads((out / "results.json").read_text())
    rows: dict[str, dict] = {}
    for r in doc["rows"]:
        rows.setdefault(r["method"], {})[(r["seed"], r["index"])] = r
    return doc, rows


def test_score_figures_draw_what_the_scoring_read_and_call_no_method(exported, tmp_path, monkeypatch, capsys):
    """The panels and pixel figures of ``score`` come from the predictions the scoring made: the submission's
    files as read once, and each ``-m`` method's output; the figures call neither again."""
    from inpaintenv.benchmark import figures

    calls = []
    monkeypatch.setattr(figures, "run_method", lambda *a, **k: calls.append(a[-1]) or pytest.fail("called again"))
    out = tmp_path / "run"
    argv = [a for a in score_argv(exported, exported / "predictions", out, "-m", "harmonic", "--figure-frames", "1")
            if a != "-q"]
    assert main(argv) == 0
    assert calls == []
    assert "kept from the run's own predictions; no method runs again" in capsys.readouterr().err
    for name in ("frame_0000.png", "error_vs_distance.png", "error_vs_nearest.png"):
        assert (out / "figures" / name).is_file(), name


def test_score_writes_the_benchmark_run_folder_with_classical_rows(exported, tmp_path, capsys, fill_method):
    out = tmp_path / "run"
    argv = score_argv(exported, exported / "predictions", out, "-m", "harmonic", "--figure-frames", "1")
    assert main(argv) == 0
    table = capsys.readouterr().out
    assert "| telea-script | rect-v1 |" in table and "| harmonic | rect-v1 |" in table
    assert "Best submitted vs strongest classical" in table  # the submission is labelled what it is
    for name in ("results.json", "results.csv", "results.md", "table.csv", "by_drive.csv", "run.json",
                 "figures/frame_0000.png", "figures/error_vs_hole_size.png"):
        assert (out / name).is_file(), name
    doc, rows = rows_by_method(out)
    assert doc["meta"]["command"].startswith("inpaintenv score")
    assert doc["meta"]["submission"]["missing"] == [] and doc["meta"]["submission"]["identity"].startswith("predictions:")
    assert doc["meta"]["submission"]["trusted"] is True  # exported with two seeds
    assert set(rows["telea-script"]) == set(rows["harmonic"]) and len(rows["harmonic"]) == 16
    # The submission's rows are evaluate()'s of the same method, bit for bit (through JSON).
    manifest = read_manifest(exported / "inputs.key.json")
    reference = evaluate(fill_method, open_truth(manifest), "rect-v1", manifest.seeds, progress=False)
    for ref in reference.rows:
        row = rows["telea-script"][(ref["seed"], ref["index"])]
        assert [row[c] for c in ("frame_id", "hole_fraction", *METRIC_COLUMNS)] == [
            ref[c] for c in ("frame_id", "hole_fraction", *METRIC_COLUMNS)]
    # The classical rows are exactly those `inpaintenv benchmark` makes on the same data.
    bench = tmp_path / "bench"
    assert main(["benchmark", *DATA, "-m", "harmonic", "--seed", "0", "--seed", "1", "--figure-frames", "0",
                 "--out", str(bench), "-q"]) == 0
    _, bench_rows = rows_by_method(bench)
    capsys.readouterr()
    for key, row in bench_rows["harmonic"].items():
        assert {k: v for k, v in rows["harmonic"][key].items() if k != "ms"} == {
            k: v for k, v in row.items() if k != "ms"}
    # Rerunning resumes: nothing is scored again, the same table comes out.
    assert main(argv) == 0
    assert capsys.readouterr().out == table


def test_changed_predictions_do_not_resume_into_old_rows(exported, tmp_path, capsys):
    out = tmp_path / "run"
    preds = tmp_path / "predictions"
    shutil.copytree(exported / "predictions", preds)
    assert main(score_argv(exported, preds, out)) == 0
    first = min(preds.rglob("*.png"))
    hole = cv2.imread(str(exported / "inputs" / first.relative_to(preds).as_posix().replace("/velodyne_raw/", "/hole/")),
                      cv2.IMREAD_UNCHANGED) > 0
    changed = cv2.imread(str(first), cv2.IMREAD_UNCHANGED)
    changed[hole] += np.uint16(256)  # a different fill; the measured pixels stay
    cv2.imwrite(str(first), changed)
    capsys.readouterr()
    assert main(score_argv(exported, preds, out)) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "were made by predictions:" in err and "--no-resume" in err
    assert main(score_argv(exported, preds, out, "--no-resume")) == 0


def test_on_missing_skip_scores_the_rest(exported, tmp_path, capsys):
    preds = tmp_path / "predictions"
    shutil.copytree(exported / "predictions", preds)
    gone = sorted(preds.rglob("*.png"))[3]
    gone.unlink()
    out = tmp_path / "run"
    assert main(score_argv(exported, preds, out, "--on-missing", "skip", "-m", "nearest")) == 0
    doc, rows = rows_by_method(out)
    assert doc["meta"]["submission"]["missing"] == [gone.relative_to(preds).as_posix()]
    assert len(rows["telea-script"]) == 15 and len(rows["nearest"]) == 16
    assert "| telea-script | rect-v1 | 15 |" in capsys.readouterr().out


def damage(kind, preds, hole_of):
    """Spoil one prediction of ``preds`` as ``kind`` says; returns the word the error must contain."""
    target = sorted(preds.rglob("*.png"))[2]
    raw = cv2.imread(str(target), cv2.IMREAD_UNCHANGED)
    if kind == "missing":
        target.unlink()
        return "missing"
    if kind == "8-bit":
        cv2.imwrite(str(target), (raw // 256).astype(np.uint8))
        return "8-bit"
    if kind == "rgb":
        cv2.imwrite(str(target), np.dstack([raw] * 3))
        return "3 channels"
    if kind == "size":
        cv2.imwrite(str(target), raw[:, :-8])
        return "184x64"
    if kind == "unfilled":
        raw[hole_of(target)] = 0
        cv2.imwrite(str(target), raw)
        return "--allow-unfilled"
    if kind == "stray":
        shutil.copy(target, target.with_name("extra.png"))
        return "not a prediction of this manifest"
    if kind == "corrupt":
        target.write_bytes(target.read_bytes()[:100])
        return "not a readable PNG"
    raise AssertionError(kind)


@pytest.mark.parametrize("kind", ["missing", "8-bit", "rgb", "size", "unfilled", "stray", "corrupt"])
def test_a_bad_submission_is_one_line_and_writes_nothing(exported, tmp_path, capsys, kind):
    preds = tmp_path / "predictions"
    shutil.copytree(exported / "predictions", preds)

    def hole_of(path):
        rel = path.relative_to(preds).as_posix().replace("/velodyne_raw/", "/hole/")
        return cv2.imread(str(exported / "inputs" / rel), cv2.IMREAD_UNCHANGED) > 0

    word = damage(kind, preds, hole_of)
    out = tmp_path / "run"
    capsys.readouterr()
    assert main(score_argv(exported, preds, out, "-m", "harmonic")) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert err.startswith("inpaintenv score: error: ") and word in err, err
    assert not out.exists()
    if kind == "unfilled":  # when asked, zeros in a hole are scored as 0 m
        assert main(score_argv(exported, preds, out, "--allow-unfilled")) == 0


def test_predictions_for_another_protocol_or_data_are_refused(exported, tmp_path, capsys):
    for name, option in (("freeform", ["--protocol", "freeform-v1"]), ("seed1", ["--data-seed", "1"])):
        assert main(["export", *DATA, *option, "--seed", "0", "--seed", "1", "--trusted", "--out", str(exported / name),
                     "-q"]) == 0
    capsys.readouterr()
    out = tmp_path / "run"
    assert main(score_argv(exported, exported / "predictions", out, manifest="freeform")) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "under rect-v1/" in err and "freeform-v1/" in err, err
    assert main(score_argv(exported, exported / "predictions", out, manifest="seed1")) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "none of the 16 predictions" in err and "synthetic_s1_drive" in err, err
    assert not out.exists()


def test_the_export_itself_is_not_a_submission(exported, tmp_path, capsys):
    assert main(score_argv(exported, exported / "inputs", tmp_path / "run")) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "is the export itself" in err


@pytest.mark.parametrize("inside", ["inputs", "predictions"])
def test_the_run_folder_stays_out_of_the_export_and_the_predictions(exported, capsys, inside):
    # Its figures would otherwise be PNG files the next check finds among the predictions.
    out = exported / inside / "run"
    assert main(score_argv(exported, exported / "predictions", out)) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "give a run folder outside it" in err
    assert not out.exists()


def test_a_protocol_changed_since_the_export_is_refused(exported, tmp_path, capsys):
    shutil.copytree(exported / "inputs", tmp_path / "inputs")
    path = tmp_path / "inputs.key.json"
    shutil.copy(exported / "inputs.key.json", path)
    doc = json.loads(path.read_text())
    doc["protocol"]["description"]["params"]["max_rects"] = 4
    path.write_text(json.dumps(doc))
    assert main(score_argv(tmp_path, exported / "predictions", tmp_path / "run")) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "protocol rect-v1 here differs" in err
    assert not (tmp_path / "run").exists()


def test_kitti_ground_truth_changed_or_missing_is_named(kitti_root, tmp_path, capsys, fill_script):
    """A KITTI root whose files differ from the export's: each file is named, nothing written."""
    assert main(["export", "--kitti-root", str(kitti_root), "--split", "val", "--out", str(tmp_path / "inputs"),
                 "-q"]) == 0
    manifest = json.loads((tmp_path / "inputs.key.json").read_text())
    fill_script["main"](tmp_path / "inputs", tmp_path / "predictions")
    root = tmp_path / "kitti"  # a copy of only the listed ground truth
    for frame in manifest["frames"]:
        (root / frame["ground_truth"]).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(kitti_root / frame["ground_truth"], root / frame["ground_truth"])
    argv = score_argv(tmp_path, tmp_path / "predictions", tmp_path / "run", "--kitti-root", str(root))
    capsys.readouterr()
    assert main(argv) == 0
    shutil.rmtree(tmp_path / "run")
    listed = root / manifest["frames"][0]["ground_truth"]
    raw = cv2.imread(str(listed), cv2.IMREAD_UNCHANGED)
    raw[raw > 0] += 1
    cv2.imwrite(str(listed), raw)
    assert main(argv) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(listed) in err and "not the file" in err, err
    listed.unlink()
    assert main(argv) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(listed) in err and "missing" in err, err
    assert not (tmp_path / "run").exists()
