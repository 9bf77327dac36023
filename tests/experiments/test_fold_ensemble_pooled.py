"""experiments/fold_ensemble.py pooled: the headline of a run folder pooled over its drives."""

from __future__ import annotations

import numpy as np
import pytest

from inpaintenv.metrics import psnr_of
from inpaintenv.report.results import EvaluationResult


def _row(method: str, drive: str, index: int, rmse: float) -> dict:
    """A possible row (inpaintenv.values.rows): its MAE at most its RMSE, its PSNR its RMSE's."""
    metrics = {f"{where}_{m}": value for where, e in (("hole", rmse), ("all", rmse / 2))
               for m, value in (("rmse", e), ("mae", e / 2), ("irmse", 1.0), ("imae", 1.0),
                                ("psnr", float(psnr_of(e, 80.0))))}
    return {"method": method, "protocol": "rect-v1", "seed": 0, "index": index, "frame_id": f"{drive}/{index}",
            "drive": drive, **metrics, "hole_count": 100, "all_count": 400, "hole_fraction": 0.1, "ms": 1.0}


def test_pooled_ratio_over_drives_and_one_learned_method(tmp_path, capsys, load_experiment):
    script = load_experiment("fold_ensemble")
    rows = []
    for i, drive in enumerate(["a", "a", "b", "b"]):
        rows += [_row("harmonic", drive, i, 10.0 + i), _row("scanline", drive, i, 20.0),
                 _row("mine", drive, i, 8.0), _row("other", drive, i, 30.0)]
    EvaluationResult(rows=rows).to_json(tmp_path / "results.json")
    assert script.main(["pooled", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    ratio = 8.0 / np.mean([10.0, 11.0, 12.0, 13.0])  # harmonic is the strongest over both drives
    assert "(2 drives pooled)" in out and "mine 8.00" in out and f"{ratio:.2f}" in out
    assert script.main(["pooled", str(tmp_path), "--learned", "other"]) == 0
    assert "other 30.00" in capsys.readouterr().out
    assert script.main(["pooled", str(tmp_path), "--learned", "nope"]) == 1
    assert script.main(["pooled", str(tmp_path / "missing")]) == 1


def test_gate_ceiling_takes_the_best_method_of_each_frame_mask(tmp_path, capsys, load_experiment):
    script = load_experiment("fold_ensemble")
    rows = []
    for i, (mine, harmonic, scanline) in enumerate([(8.0, 10.0, 12.0), (9.0, 6.0, 7.0), (5.0, 5.0, 4.0)]):
        rows += [_row("mine", "a", i, mine), _row("harmonic", "a", i, harmonic), _row("scanline", "a", i, scanline)]
    no_truth = {c: float("nan") for c in ("hole_rmse", "hole_mae", "hole_irmse", "hole_imae", "hole_psnr")}
    rows.append({**_row("other", "a", 0, 1.0), **no_truth, "hole_count": 0})  # no truth in its hole: never counted
    result = EvaluationResult(rows=rows)
    gate = script.gate_ceiling(result, "mine", "harmonic")
    assert gate["n"] == 3
    assert np.isclose(gate["ceiling"], (8.0 + 6.0 + 4.0) / (10.0 + 6.0 + 5.0))
    assert np.isclose(gate["learned_worse"], 2 / 3)  # frames 1 and 2: a classical fill beats mine
    result.to_json(tmp_path / "results.json")
    assert script.main(["pooled", str(tmp_path), "--learned", "mine", "--gate-ceiling"]) == 0
    out = capsys.readouterr().out
    assert "reaches 0.857x harmonic" in out and "on 67 % of 3 frame-masks" in out
    with pytest.raises(ValueError, match="no classical method"):
        script.gate_ceiling(EvaluationResult(rows=rows[:1]), "mine", "harmonic")
    with pytest.raises(ValueError, match="no frame-mask"):
        script.gate_ceiling(EvaluationResult(rows=rows[-1:] + rows[1:2]), "other", "harmonic")
