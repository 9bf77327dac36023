"""Figures use one plotting library: no module of the packages draws lines, shapes or text itself
(OpenCV's drawing functions, Pillow's ImageDraw/ImageFont); matplotlib draws them (:mod:`inpaintenv.report.plots`)."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
#: OpenCV's drawing functions (lines, shapes, text).
CV2_DRAWING = frozenset({
    "line", "arrowedLine", "circle", "ellipse", "rectangle", "polylines", "fillPoly", "fillConvexPoly",
    "drawContours", "drawMarker", "putText", "getTextSize", "ellipse2Poly",
})
#: Pillow's modules for drawing and setting text.
PIL_DRAWING = frozenset({"ImageDraw", "ImageDraw2", "ImageFont"})


def drawing_calls(source: str) -> list[str]:
    """Each place in ``source`` that draws by hand: ``cv2.<drawing function>`` or Pillow's drawing modules."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Attribute) and node.attr in CV2_DRAWING and getattr(node.value, "id", None) == "cv2":
            found.append(f"line {node.lineno}: cv2.{node.attr}")
        elif isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] == "PIL":
            names = {node.module.split(".")[-1], *(a.name for a in node.names)}
            found += [f"line {node.lineno}: PIL.{n}" for n in sorted(names & PIL_DRAWING)]
        elif isinstance(node, ast.Import):
            found += [f"line {node.lineno}: {a.name}" for a in node.names if a.name.split(".")[-1] in PIL_DRAWING]
    return found


def test_the_check_finds_hand_drawing():
    source = ("import cv2\nfrom PIL import Image, ImageDraw\nimport PIL.ImageFont\n"
              "cv2.putText(a, 't', (0, 0), 0, 1, 255)\ncv2.line(a, (0, 0), (1, 1), 255)\ncv2.resize(a, (2, 2))\n")
    assert drawing_calls(source) == ["line 2: PIL.ImageDraw", "line 3: PIL.ImageFont", "line 4: cv2.putText",
                                     "line 5: cv2.line"]


def test_no_module_draws_lines_or_text_itself():
    found = {}
    for package in ("inpaintenv", "estimators"):
        for path in sorted((ROOT / package).rglob("*.py")):
            if calls := drawing_calls(path.read_text(encoding="utf-8")):
                found[str(path.relative_to(ROOT))] = calls
    assert found == {}, f"draw figures with matplotlib (inpaintenv.report.plots), not by hand: {found}"
