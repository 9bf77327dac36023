"""experiments/blend_lodo.py: the leave-one-drive-out fit on cached per-pixel features."""

from __future__ import annotations

import pytest

pytest.importorskip("torch")


def test_lodo_script_fits_a_variant_on_a_tiny_cache(load_experiment, tmp_path):
    """blend_lodo's fit path on a hand-made cache: three drives, per-drive ratios."""
    import json

    import numpy as np

    lodo = load_experiment("blend_lodo")
    rng = np.random.default_rng(0)
    n_ch = len(lodo.CHANNELS)

    def block(n_samples, px):
        x = rng.uniform(5, 30, (n_samples * px, n_ch)).astype(np.float32)
        x[:, lodo.CHANNELS.index("gap-l"):] = rng.integers(1, 40, (len(x), n_ch - lodo.CHANNELS.index("gap-l")))
        return {"x": x, "y": x[:, 0] * 0.9 + 1, "row": np.zeros(len(x), np.int16),
                "sample": np.repeat(np.arange(n_samples), px).astype(np.int32)}

    drives = ["a_sync", "b_sync", "c_sync"]
    meta_eval = [{"split": "train", "drive": d, "frame": i, "kind": "eval", "seed": 0} for d in drives for i in range(2)]
    meta_train = [{"split": "train", "drive": d, "frame": i, "kind": "train-1", "seed": 1000}
                  for d in drives for i in range(2)]
    for kind, meta in (("eval", meta_eval), ("train-1", meta_train)):
        np.savez(tmp_path / f"{kind}.npz", **block(len(meta), 64))
        (tmp_path / f"{kind}.json").write_text(json.dumps(meta))
    lodo.VARIANTS["tiny"] = {"candidates": lodo.FIVE, "keep": ["1"], "endpoints": True, "width": 4, "layers": 1}
    out = tmp_path / "fit.json"
    lodo.main(["fit", "--cache", str(tmp_path), "--variant", "tiny", "--epochs", "1", "--json", str(out)])
    result = json.loads(out.read_text())["tiny"]
    assert set(result) == set(drives)
    assert all(r["frames"] == 2 and r["ratio"] > 0 and r["ci"][0] <= r["ratio"] <= r["ci"][1] for r in result.values())
