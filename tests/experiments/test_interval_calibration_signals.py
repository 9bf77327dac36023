"""experiments/interval_calibration.py signals: each fold model ranks its left-out day by every variant's scale."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from inpaintenv.data.io import write_depth_png

DAYS = {"2011_09_26": ("9001", "9002"), "2011_09_30": ("9018", "9020")}


class Member:
    def __init__(self, fill: float) -> None:
        self.fill = np.float32(fill)

    def predict(self, X):
        x = np.asarray(X, dtype=np.float32)
        return np.where(np.isnan(x), self.fill, x)


class FoldEnsemble:
    """A fitted stand-in of a fold model: two members (10 m and 14 m), their mean, the drives it saw."""

    def __init__(self, seen: list[str], members: bool = True) -> None:
        self.training_drives_ = seen
        if members:
            self.estimators_ = [Member(10.0), Member(14.0)]

    def predict(self, X):
        return Member(12.0).predict(X)


@pytest.fixture(scope="module")
def two_days(tmp_path_factory):
    root = tmp_path_factory.mktemp("kitti")
    rng = np.random.default_rng(0)
    ramp = np.linspace(4.0, 40.0, 375, dtype=np.float32)[:, None] * np.ones((1, 1242), np.float32)
    for day, numbers in DAYS.items():
        for n in numbers:
            folder = root / "train" / f"{day}_drive_{n}_sync" / "proj_depth" / "groundtruth" / "image_02"
            folder.mkdir(parents=True)
            for f in range(1):
                depth = np.where(rng.random((375, 1242)) < 0.3, ramp * (1 + 0.05 * rng.standard_normal()), 0.0)
                write_depth_png(folder / f"{f:010d}.png", depth.astype(np.float32))
    return root


def fold_args(two_days) -> list[str]:
    return ["--kitti-root", str(two_days), "--frames-per-drive", "0",
            *[a for day in DAYS for a in ("--fold", f"{day}=m-{day}")]]


def test_every_variant_on_every_fold(load_experiment, two_days, tmp_path, monkeypatch, capsys):
    import estimators.learned

    monkeypatch.setattr(estimators.learned, "load", lambda path: FoldEnsemble([]))
    module = load_experiment("interval_calibration")
    cuts = module.main(["signals", *fold_args(two_days), "--json", str(tmp_path / "cuts.json")])
    assert set(cuts) == set(module.VARIANTS)
    assert all(set(row) == set(DAYS) and all(-1 < v < 1 for v in row.values()) for row in cuts.values())
    assert json.loads((tmp_path / "cuts.json").read_text()) == cuts
    out = capsys.readouterr().out
    assert "| variant | 2011_09_26 | 2011_09_30 |" in out and "| boosted trees |" in out


def test_a_model_without_members_skips_their_variants(load_experiment, two_days, monkeypatch):
    import estimators.learned

    monkeypatch.setattr(estimators.learned, "load", lambda path: FoldEnsemble([], members=False))
    module = load_experiment("interval_calibration")
    cuts = module.main(["signals", *fold_args(two_days)])
    assert set(cuts) == {name for name, (signals, _) in module.VARIANTS.items() if "members" not in signals}


def test_the_cut_ranks_by_the_score(load_experiment):
    module = load_experiment("interval_calibration")
    error = np.array([0.1, 0.2, 0.3, 0.4, 5.0])
    frame = {"error": error, "depth": np.log(np.array([1.0, 2.0, 3.0, 4.0, 50.0]))}
    # Ranked by depth, the one large error is the 20 % dropped.
    expected = 1 - math.sqrt(np.mean(error[:4] ** 2)) / math.sqrt(np.mean(error ** 2))
    assert module.keep_80_cut([frame], ("depth",), lambda F: F[:, 0]) == pytest.approx(expected)
    assert module.keep_80_cut([frame], ("depth",), lambda F: -F[:, 0]) < 0


def test_a_fold_without_unseen_drives_is_refused(load_experiment, two_days, monkeypatch):
    import estimators.learned

    every = [f"{day}_drive_{n}_sync" for day, numbers in DAYS.items() for n in numbers]
    monkeypatch.setattr(estimators.learned, "load", lambda path: FoldEnsemble(every))
    with pytest.raises(SystemExit, match="never saw"):
        load_experiment("interval_calibration").main(["signals", *fold_args(two_days)])
