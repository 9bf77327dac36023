"""``inpaintenv.filling.plan``: which files a ``fill`` run reads and which files each becomes."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from inpaintenv.data import write_depth_file
from inpaintenv.exceptions import InvalidInputError
from inpaintenv.filling import FORMATS, POINT_FORMATS, FillJob, plan


@pytest.fixture
def tree(tmp_path) -> Path:
    """``in/``: two PNGs in drive folders, an ``.npy``, a scan, a README and a hidden temporary."""
    d = np.full((8, 16), 5.0, np.float32)
    write_depth_file(tmp_path / "in" / "a" / "0001.png", d)
    write_depth_file(tmp_path / "in" / "b" / "0002.png", d)
    np.save(tmp_path / "in" / "c.npy", d)
    (tmp_path / "in" / "s.bin").write_bytes(np.zeros((3, 4), np.float32).tobytes())
    (tmp_path / "in" / "README.txt").write_text("notes")
    (tmp_path / "in" / "a" / ".inpaintenv-tmp-1-ab").write_bytes(b"")
    return tmp_path / "in"


def _rel(jobs: list[FillJob], out: Path) -> dict[str, list[str]]:
    return {j.rel.as_posix(): [o.relative_to(out).as_posix() for o in j.all_outputs] for j in jobs}


def test_a_folder_becomes_one_job_per_depth_file_or_scan_at_its_relative_path(tree, tmp_path):
    out = tmp_path / "out"
    jobs, missing, ignored = plan([tree], out)
    assert _rel(jobs, out) == {"a/0001.png": ["a/0001.png"], "b/0002.png": ["b/0002.png"], "c.npy": ["c.png"],
                               "s.bin": ["s.png"]}
    assert {j.rel.as_posix() for j in jobs if j.is_scan} == {"s.bin"}
    assert all(j.out == out for j in jobs) and not missing
    assert ignored == [tree / "README.txt"]  # left alone and counted; the hidden temporary is not even seen


@pytest.mark.parametrize("format", sorted(FORMATS))
@pytest.mark.parametrize("points", [p for p in POINT_FORMATS if p is not None])
def test_formats_points_and_confidence_name_every_output(tree, tmp_path, format, points):
    out = tmp_path / "out"
    jobs, _, _ = plan([tree / "s.bin", tree / "c.npy"], out, format=format, points=points, confidence=True)
    scan, npy = jobs
    depth = [f"s{s}" for s in FORMATS[format]]
    assert [o.name for o in scan.outputs] == depth + [f"s{s}" for s in POINT_FORMATS[points]]
    assert [o.name for o in npy.outputs] == [f"c{s}" for s in FORMATS[format]]  # points are for scans only
    assert [(lo.name, hi.name) for lo, hi in scan.intervals] == [(f"s_low{s}", f"s_high{s}") for s in FORMATS[format]]


def test_a_missing_input_or_a_file_of_another_kind_given_by_name_is_reported_not_raised(tree, tmp_path):
    jobs, missing, _ = plan([tree / "nowhere", tree / "README.txt", tree / "c.npy"], tmp_path / "out")
    assert [j.source for j in jobs] == [tree / "c.npy"]
    assert [p for p, _ in missing] == [tree / "nowhere", tree / "README.txt"]
    assert "no such file or folder" in missing[0][1] and "not a depth file or scan" in missing[1][1]


def test_a_mask_folder_inside_the_input_is_not_read_as_input(tree, tmp_path):
    write_depth_file(tree / "masks" / "a" / "0001.png", np.ones((8, 16), np.float32))
    jobs, _, _ = plan([tree], tmp_path / "out", protect=[tree / "masks"])
    assert not any("masks" in j.rel.parts for j in jobs) and len(jobs) == 4


@pytest.mark.parametrize("case, match", [
    ("out inside the input", "lies inside the input folder"),
    ("out is a file", "is a file; give a folder"),
    ("two inputs, one output", "would be written to the same output"),
    ("bad format", "format must be one of"),
    ("bad points", "points must be None"),
])
def test_plans_that_would_write_over_inputs_or_twice_are_refused(tree, tmp_path, case, match):
    out, kwargs, inputs = tmp_path / "out", {}, [tree]
    if case == "out inside the input":
        out = tree / "filled"
    elif case == "out is a file":
        out = tree / "README.txt"
    elif case == "two inputs, one output":
        np.save(tree / "a" / "0001.npy", np.ones((8, 16)))  # 0001.png and 0001.npy both become a/0001.png
    elif case == "bad format":
        kwargs = {"format": "tiff"}
    else:
        kwargs = {"points": "las"}
    with pytest.raises(InvalidInputError, match=match):
        plan(inputs, out, **kwargs)


def test_two_input_folders_with_the_same_inner_paths_are_refused_listing_every_pair(tmp_path):
    """Two drives' folders into one --out: every colliding pair counted, the first named, the way out said;
    the folder holding both, given as one INPUT, keeps each drive's folder."""
    d = np.full((8, 16), 5.0, np.float32)
    drives = [tmp_path / "day" / f"drive_{k}" for k in (1, 2)]
    for drive in drives:
        for frame in range(4):
            write_depth_file(drive / "image_02" / f"{frame:010d}.png", d)
    out = tmp_path / "out"
    with pytest.raises(InvalidInputError) as info:
        plan(drives, out)
    message = str(info.value)
    assert message.startswith("4 pairs of inputs would be written to the same output (")
    assert f"{drives[0] / 'image_02' / '0000000000.png'} and {drives[1] / 'image_02' / '0000000000.png'}" in message
    assert "and 1 more" in message and "give the folder that holds them as one INPUT" in message
    jobs, _, _ = plan([tmp_path / "day"], out)
    assert sorted(j.rel.as_posix() for j in jobs)[::4] == ["drive_1/image_02/0000000000.png",
                                                           "drive_2/image_02/0000000000.png"]
