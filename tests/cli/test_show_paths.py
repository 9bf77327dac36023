"""``inpaintenv show PATH``: a colour picture of a depth file, of every depth file of a fill output folder
(with its interval width) and of a point cloud (.bin, .ply); anything else one clear line."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from inpaintenv.cli import main
from inpaintenv.data import write_depth_png
from inpaintenv.data.projection import write_points_bin, write_points_ply

pytest.importorskip("estimators.classical")


def _colours(path) -> int:
    img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    assert img is not None and img.dtype == np.uint8 and img.ndim == 3
    return len(np.unique(img[..., :3].reshape(-1, 3), axis=0))


@pytest.fixture
def depth_file(tmp_path):
    rng = np.random.default_rng(0)
    depth = np.where(rng.random((48, 160)) < 0.5, rng.uniform(2, 60, (48, 160)), 0.0)
    write_depth_png(tmp_path / "in" / "a.png", depth)
    return tmp_path / "in" / "a.png"


def test_a_depth_file(depth_file, tmp_path, capsys):
    assert main(["show", str(depth_file), "--out", str(tmp_path / "a.png")]) == 0
    assert _colours(tmp_path / "a.png") > 50  # depth in colour, not a black 16-bit picture
    assert "pixels with depth" in capsys.readouterr().err


def test_a_fill_output_folder_shows_each_file_with_its_interval_width(depth_file, tmp_path, capsys):
    out = tmp_path / "filled"
    assert main(["fill", str(depth_file), "--missing", "-m", "scanline", "--confidence", "--out", str(out), "-q"]) == 0
    assert main(["show", str(out), "--out", str(tmp_path / "pics")]) == 0
    assert [p.name for p in (tmp_path / "pics").iterdir()] == ["a_png.png"]  # not its _low and _high
    assert "and the interval width" in capsys.readouterr().err
    plain = tmp_path / "plain.png"
    assert main(["show", str(depth_file), "--out", str(plain)]) == 0
    assert cv2.imread(str(tmp_path / "pics" / "a_png.png")).shape[0] > cv2.imread(str(plain)).shape[0]  # two tiles


@pytest.mark.parametrize("suffix, writer", [(".bin", write_points_bin), (".ply", write_points_ply)])
def test_a_point_cloud_from_above_and_from_the_sensor(tmp_path, suffix, writer):
    rng = np.random.default_rng(0)
    pts = np.column_stack([rng.uniform(-40, 40, 5000), rng.uniform(-20, 20, 5000), rng.uniform(-2, 1, 5000),
                           rng.random(5000)]).astype(np.float32)
    writer(tmp_path / f"s{suffix}", pts)
    assert main(["show", str(tmp_path / f"s{suffix}"), "--out", str(tmp_path / "s.png")]) == 0
    assert _colours(tmp_path / "s.png") > 50


def test_what_is_not_a_picture_is_one_line(tmp_path, capsys):
    (tmp_path / "x.ply").write_bytes(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n")
    assert main(["show", str(tmp_path / "x.ply"), "--out", str(tmp_path / "x.png")]) == 1
    assert "binary little-endian" in capsys.readouterr().err
    assert main(["show", str(tmp_path / "missing.png")]) == 1
    assert "no such file" in capsys.readouterr().err
    assert not (tmp_path / "x.png").exists()
