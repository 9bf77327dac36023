"""Score methods that run anywhere: export the occluded inputs as files, score a folder of predictions.

The round trip of ``inpaintenv export`` / ``inpaintenv score`` in Python::

    from inpaintenv.submission import export, score
    from inpaintenv.data import write_depth_png

    manifest = export("inputs", protocol="rect-v1", seeds=[0])  # the score key; its kit is inputs/
    for item in manifest.items:
        depth = manifest.read_input(item)          # metres, 0 = hole or no measurement
        hole = manifest.read_hole(item)            # True = fill
        write_depth_png(f"predictions/{item.input}", my_fill(depth, hole))
    result = score(manifest, "predictions", name="mine")

The kit (``inputs/``: the inputs, the masks and a ``manifest.json`` naming no ground
truth) goes to whoever runs the method; the score key (``inputs.key.json``) stays with
whoever scores. See ``docs/submissions.md``, which says what a kit protects and what not.
"""

from .export import export
from .manifest import Frame, Item, Manifest, ManifestError, read_manifest
from .predictions import SubmissionError, SubmittedPredictions, check_predictions
from .score import prepare, score

__all__ = [
    "Frame",
    "Item",
    "Manifest",
    "ManifestError",
    "SubmissionError",
    "SubmittedPredictions",
    "check_predictions",
    "export",
    "prepare",
    "read_manifest",
    "score",
]
