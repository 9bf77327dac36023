"""What a fresh interpreter sees of ``estimators`` with torch installed, checked in ONE child process.

Starting Python and importing torch is most of each check's cost, so a single child runs the
steps below in order and prints a JSON report; each test asserts on its part. The order keeps
every step's starting state what a fresh process would have, and the report records that
state, so a step that an earlier one made vacuous fails instead of passing:

1. ``import estimators`` imports no torch; ``estimators.learned.UNetInpainter`` then does.
2. ``from estimators.learned import load`` registers every family (``load`` once imported the
   prior family inside itself, an import circle: prior subclasses neural), and ``load`` reads
   a ``PriorUNetInpainter`` checkpoint as that class, predicting what the saved model did.

The releases' fresh-process check (one interpreter per registry name, each the first learned
load of its process) stays in ``test_releases.py``; the torch-blocked children stay in
``tests/test_torch_optional.py``.
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from estimators.learned import PriorUNetInpainter
from inpaintenv.data import SyntheticStreets

pytestmark = pytest.mark.slow

#: The child: argv is the checkpoint, the input frame and where to save its prediction.
CHILD = textwrap.dedent("""
    import json, sys, traceback
    report = {}
    try:
        import estimators
        report["torch_after_import_estimators"] = "torch" in sys.modules
        report["unet_class"] = estimators.learned.UNetInpainter.__name__
        report["torch_after_unet"] = "torch" in sys.modules
        report["prior_before_load"] = "estimators.learned._prior" in sys.modules
        from estimators.learned import load
        report["prior_after_load"] = "estimators.learned._prior" in sys.modules
        import numpy as np
        est = load(sys.argv[1])
        report["loaded_class"] = type(est).__name__
        np.save(sys.argv[3], est.predict(np.load(sys.argv[2])))
    except BaseException:
        report["error"] = traceback.format_exc()
    print(json.dumps(report))
""")


@pytest.fixture(scope="module")
def fresh(tmp_path_factory) -> dict:
    """The child's report, plus the prediction the parent's model made and the child's."""
    tmp = tmp_path_factory.mktemp("fresh")
    frames = SyntheticStreets(n=4, frame_shape=(32, 96), frames_per_drive=2)
    est = PriorUNetInpainter(width=4, levels=1, batch_size=2, max_steps=2, random_state=0, num_threads=1)
    path = est.fit(frames).save(tmp / "model")
    x = frames[0].copy()
    x[8:16, 20:40] = np.nan
    np.save(tmp / "x.npy", x)
    done = subprocess.run([sys.executable, "-c", CHILD, str(path), str(tmp / "x.npy"), str(tmp / "got.npy")],
                          check=False, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0 and done.stdout.strip(), done.stderr
    report = json.loads(done.stdout.strip().splitlines()[-1])
    got = np.load(tmp / "got.npy") if (tmp / "got.npy").is_file() else None
    return {"report": report, "want": est.predict(x), "got": got}


def _step(fresh: dict, key: str):
    report = fresh["report"]
    assert key in report, f"the child stopped before {key!r}:\n{report.get('error', '')}"
    return report[key]


def test_import_estimators_does_not_import_torch(fresh):
    assert _step(fresh, "torch_after_import_estimators") is False
    assert _step(fresh, "unet_class") == "UNetInpainter"
    assert _step(fresh, "torch_after_unet") is True


def test_a_fresh_process_loads_a_prior_checkpoint_through_estimators_learned(fresh):
    # The neural family alone must not have pulled the prior in, or the next check is vacuous.
    assert _step(fresh, "prior_before_load") is False
    assert _step(fresh, "prior_after_load") is True  # loading registered every family
    assert _step(fresh, "loaded_class") == "PriorUNetInpainter"
    assert "error" not in fresh["report"], fresh["report"]["error"]
    np.testing.assert_array_equal(fresh["got"], fresh["want"])
