"""open_source(): synthetic by default (reproducible everywhere), KITTI only when asked."""

from __future__ import annotations

import re

import pytest

from inpaintenv.data import KittiDepth, Subset, SyntheticStreets, open_source


def test_default_is_synthetic_even_with_the_environment_variable(monkeypatch, tmp_path):
    monkeypatch.setenv("INPAINTENV_KITTI_ROOT", str(tmp_path))
    ds = open_source()
    assert isinstance(ds, SyntheticStreets) and len(ds) == 64
    small = open_source(n_frames=5, seed=2, kind="velodyne_raw")
    assert len(small) == 5 and small.seed == 2 and small.kind == "velodyne_raw"


@pytest.mark.kitti
def test_kitti_when_a_root_is_given(kitti_root, kitti_layout):
    full = open_source(kitti_root)
    assert isinstance(full, KittiDepth) and len(full) == sum(kitti_layout("train").values())
    first = open_source(kitti_root, n_frames=7)
    assert isinstance(first, Subset) and first.frame_ids == full.frame_ids[:7]
    n_val = sum(kitti_layout("val").values())
    assert len(open_source(kitti_root, split="val", n_frames=10)) == min(n_val, 10)


@pytest.mark.parametrize("kwargs, error, match", [
    ({"n_frames": 0}, ValueError, "n_frames must be >= 1"), ({"n_frames": 2.5}, TypeError, "n_frames must be an integer"),
    # int("abc") said "invalid literal for int() with base 10: 'abc'".
    ({"n_frames": "abc"}, TypeError, r"^n_frames must be an integer, got 'abc' \(str\)$"),
])
def test_bad_n_frames(kwargs, error, match):
    with pytest.raises(error, match=match):
        open_source(**kwargs)


@pytest.mark.parametrize("argv, message", [
    (["--frame-shape", "60000", "60000"],
     "--frame-shape 60000 x 60000 is 3,600,000,000 pixels, more than the 50,000,000 a frame may have (MAX_FRAME_PIXELS)"),
    (["--frame-shape", "4", "600"], "--frame-shape must be at least 8 x 8 (H x W), got 4 x 600"),
    (["--n-frames", "1000000000"],
     "--n-frames 1000000000 is more than the 1,000,000 frames the synthetic source may have (MAX_SYNTHETIC_FRAMES)"),
])
def test_cli_refuses_unbounded_synthetic_sizes_in_one_line_before_any_work(argv, message, capsys):
    # --frame-shape 60000 60000 allocated without bound (or ended in MemoryError).
    from inpaintenv.cli import main

    assert main(["info", "--synthetic", *argv]) == 1
    assert capsys.readouterr().err.strip() == f"inpaintenv info: error: {message}"


def test_threads_option_type_names_its_limit():
    # --threads 100000 ended in torch's "failed to map segment".
    import argparse

    from inpaintenv.cli.options import MAX_THREADS, thread_count

    assert thread_count("3") == 3 and thread_count(str(MAX_THREADS)) == MAX_THREADS
    assert thread_count("0") == 0  # refused by the estimator's num_threads check, which names it
    for bad, words in (("100000", f"must be at most {MAX_THREADS} (MAX_THREADS"),
                       ("abc", "must be a whole number of threads, got 'abc'")):
        with pytest.raises(argparse.ArgumentTypeError, match=re.escape(words)):
            thread_count(bad)


def test_split_must_be_a_string(tmp_path):
    with pytest.raises(TypeError, match="split must be a string"):
        open_source(tmp_path, split=["train"])


def test_dense_needs_synthetic(tmp_path):
    with pytest.raises(ValueError, match="dense"):
        open_source(tmp_path, kind="dense")


def test_train_threads_is_bounded_in_option_parsing(capsys):
    from inpaintenv.cli import main
    from inpaintenv.cli.options import MAX_THREADS

    with pytest.raises(SystemExit):
        main(["train", "--threads", "100000", "--synthetic"])
    err = capsys.readouterr().err
    assert f"argument --threads: must be at most {MAX_THREADS} (MAX_THREADS" in err and "got 100000" in err
