"""experiments/fold_ensemble.py join: saved models joined into one ensemble checkpoint."""

from __future__ import annotations

import numpy as np
import pytest


def test_joined_checkpoint_predicts_the_mean_of_its_members(tmp_path, load_experiment, tiny_models):
    from estimators.learned import MeanEnsembleInpainter
    from estimators.learned import load
    from inpaintenv.data import SyntheticStreets

    script = load_experiment("fold_ensemble")
    frames = SyntheticStreets(n=3, frame_shape=(48, 128))  # the frames the tiny models were trained on
    a, b = tiny_models["blend"], tiny_models["blend-1"]  # two blends of different seeds
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
