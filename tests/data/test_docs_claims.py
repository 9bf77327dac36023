"""What the first-hour docs say about the data, the baselines and the tests is true."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def text(name: str) -> str:
    return (ROOT / name).read_text()


def test_no_page_calls_one_classical_method_the_reference_learned_models_must_beat():
    # The README divides by the strongest classical method on the same frames (scanline on
    # the val frame) while two pages called harmonic "the reference the learned models must beat".
    pages = ["README.md", *(str(p.relative_to(ROOT)) for p in (ROOT / "docs").rglob("*.md"))]
    assert [p for p in pages if "must beat" in text(p)] == []
    for page in ("docs/baselines.md", "docs/estimators.md"):
        assert "strongest classical method on the same frames" in " ".join(text(page).split())


def test_neural_md_names_lambda_and_beta_where_the_search_sets_them():
    page = text("docs/neural.md")
    assert "`hole_weight` is λ and `tv_weight` is β" in page


def test_readme_installs_cpu_torch_first_and_says_how_to_run_the_kitti_tests():
    readme = text("README.md")
    assert readme.index("download.pytorch.org/whl/cpu") < readme.index('pip install -e ".[test]"')
    assert "INPAINTENV_KITTI_ROOT=<KITTI root> python -m pytest -m kitti" in readme
    assert re.search(r"about \d+ minutes on two (idle )?cores", readme)


@pytest.mark.kitti
def test_baselines_md_names_the_frames_its_command_scores(kitti_root, kitti_layout):
    # It said "the 80 train frames of its first two drives"; the slice's first two drives
    # are 0001 and 9001, the command scores 9001 and 9002.
    page = " ".join(text("docs/baselines.md").split())
    command = re.search(r"--drives ([^`\n]+)", text("docs/baselines.md")).group(1).split()
    train = kitti_layout("train")
    counts = {d: train[d] for d in command if d in train}
    # The page names what its table was computed on; nothing here assumes the slice's size.
    assert len(counts) == 2 and f"the {sum(counts.values())} `train` frames of two of its `train` drives" in page
    for drive, n in counts.items():
        assert f"`{drive}` ({n}" in page
    assert "first two drives" not in page
