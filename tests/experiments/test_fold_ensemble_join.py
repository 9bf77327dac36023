"""experiments/fold_ensemble.py join: saved models joined into one ensemble checkpoint."""

from __future__ import annotations

import numpy as np
import pytest


def test_joined_checkpoint_predicts_the_mean_of_its_members(tmp_path, load_experiment):
    from estimators.learned import MeanEnsembleInpainter
    from estimators.learned import BlendInpainter
    from estimators.learned import load
    from inpaintenv.data import SyntheticStreets

    script = load_experiment("fold_ensemble")
    frames = SyntheticStreets(n=3, frame_shape=(48, 128))
    small = {"width": 4, "layers": 1, "epochs": 1, "masks_per_frame": 1, "pixels_per_frame": 100,
             "batch_pixels": 64, "num_threads": 1}
    a = BlendInpainter(**small).fit(frames).save(tmp_path / "a")
    b = BlendInpainter(**small, random_state=1).fit(frames).save(tmp_path / "b")
    out = tmp_path / "joined"
    assert script.main(["join", f"first={a}", f"second={b}", "--out", str(out), "--set", "second__tta=false"]) == 0
    joined = load(out)
    assert isinstance(joined, MeanEnsembleInpainter) and joined.named_estimators_["second"].tta is False
    x = frames[0].copy()
    x[10:30, 40:90] = np.nan
    members = [load(a).predict(x), load(b).set_params(tta=False).predict(x)]
    np.testing.assert_allclose(joined.predict(x)[np.isnan(x)], np.mean(members, axis=0)[np.isnan(x)], rtol=1e-6)
    for bad in ([f"first={a}", "--out", str(tmp_path / "x")],  # one member
                [f"first={a}", f"second={tmp_path / 'nothing'}", "--out", str(tmp_path / "y")],
                [f"first={a}", f"second={b}", "--set", "nope__tta=false", "--out", str(tmp_path / "z")],
                [f"{a}", f"second={b}", "--out", str(tmp_path / "w")]):
        with pytest.raises(SystemExit):
            script.main(["join", *bad])
