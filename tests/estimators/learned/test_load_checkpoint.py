"""load finds every neural class by the name its checkpoint records (issue 18).

load once imported the prior family inside itself (an import circle, prior
subclasses neural); it now lives above every learned family, so a fresh process loads a
PriorUNetInpainter checkpoint through the public estimators.learned with nothing imported
beforehand.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from estimators.learned import PriorUNetInpainter
from inpaintenv.data import SyntheticStreets


@pytest.mark.slow
def test_a_fresh_process_loads_a_prior_checkpoint_through_estimators_learned(tmp_path):
    frames = SyntheticStreets(n=4, frame_shape=(32, 96), frames_per_drive=2)
    est = PriorUNetInpainter(width=4, levels=1, batch_size=2, max_steps=2, random_state=0, num_threads=1)
    path = est.fit(frames).save(tmp_path / "model")
    x = frames[0].copy()
    x[8:16, 20:40] = np.nan
    np.save(tmp_path / "x.npy", x)
    np.save(tmp_path / "want.npy", est.predict(x))
    code = (
        "import sys, numpy as np\n"
        "from estimators.learned import load\n"
        "assert 'estimators.learned._prior' in sys.modules  # loading registered every family\n"
        f"est = load({str(path)!r})\n"
        "print(type(est).__name__)\n"
        f"np.testing.assert_array_equal(est.predict(np.load({str(tmp_path / 'x.npy')!r})), "
        f"np.load({str(tmp_path / 'want.npy')!r}))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], check=False, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "PriorUNetInpainter"
