"""``fill --preview``: an 8-bit colour picture beside each input's outputs, one more output the fill owns."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from inpaintenv.cli import main
from inpaintenv.data import SyntheticStreets, write_depth_png
from inpaintenv.masks import get_protocol

pytest.importorskip("estimators.classical")


@pytest.fixture
def inputs(tmp_path):
    data = SyntheticStreets(n=2, frame_shape=(48, 160))
    for i in range(2):
        gt = data[i]
        write_depth_png(tmp_path / "in" / f"f{i}.png", np.where(get_protocol("rect-v1").mask(gt.shape, 0, i), 0, gt))
    return tmp_path / "in"


def _picture(path):
    img = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    assert img is not None and img.dtype == np.uint8 and img.ndim == 3 and img.shape[2] in (3, 4)
    return img[..., :3]


def test_preview_beside_each_input_with_the_interval_width(inputs, tmp_path, capsys):
    out = tmp_path / "out"
    argv = ["fill", str(inputs), "--missing", "-m", "scanline", "--confidence", "--preview", "--out", str(out), "-q"]
    assert main(argv) == 0
    for i in range(2):
        img = _picture(out / f"f{i}_preview.png")
        assert len(np.unique(img.reshape(-1, 3), axis=0)) > 100  # colour maps, not a black 16-bit picture
    with_width = _picture(out / "f0_preview.png").shape[0]
    ledger = [json.loads(line) for line in (out / "inpaintenv-fill.jsonl").read_text().splitlines() if line.strip()]
    assert any("f0_preview.png" in rec.get("outputs", []) for rec in ledger)  # the fill's own output
    assert main(argv) == 0  # a rerun skips: the preview is there and recorded
    assert "2 skipped" in capsys.readouterr().err
    plain = tmp_path / "plain"
    assert main(["fill", str(inputs), "--missing", "-m", "scanline", "--preview", "--out", str(plain), "-q"]) == 0
    assert _picture(plain / "f0_preview.png").shape[0] < with_width  # input and fill only: no width tile


def test_no_preview_unless_asked(inputs, tmp_path):
    assert main(["fill", str(inputs), "--missing", "-m", "scanline", "--out", str(tmp_path / "out"), "-q"]) == 0
    assert not list((tmp_path / "out").glob("*_preview.png"))
