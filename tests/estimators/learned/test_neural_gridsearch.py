"""Cross-validated search over the loss weights, grouped by drive, serial and parallel."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest
from sklearn.model_selection import GridSearchCV, GroupKFold

from estimators.learned import UNetInpainter
from inpaintenv.data import ArrayDataset

H, W = 24, 40
GRID = {"hole_weight": [0.0, 2.0], "tv_weight": [0.0, 0.01]}


@pytest.fixture(scope="module")
def dataset() -> ArrayDataset:
    rng = np.random.default_rng(0)
    rows = np.linspace(30.0, 5.0, H, dtype=np.float32)[:, None]
    frames = np.stack([rows + k + np.zeros((1, W), np.float32) for k in range(8)])
    frames[rng.random(frames.shape) < 0.3] = 0.0
    return ArrayDataset(frames, groups=["d1", "d1", "d2", "d2", "d3", "d3", "d4", "d4"])


def tiny(**kw) -> UNetInpainter:
    return UNetInpainter(width=4, depth=2, batch_size=2, epochs=1, random_state=0, **kw)


def _run_dirs(root):
    return sorted(p for p in root.iterdir() if p.is_dir())


def test_gridsearch_grouped_by_drive_with_per_fold_checkpoints(dataset, tmp_path):
    search = GridSearchCV(tiny(num_threads=1, checkpoint_dir=tmp_path), GRID, cv=GroupKFold(2))
    search.fit(dataset, groups=dataset.groups)
    assert set(search.best_params_) == set(GRID)
    assert np.isfinite(search.cv_results_["mean_test_score"]).all()
    # 4 candidates × 2 folds + the refit on all data: one run directory each, no collision.
    assert len(_run_dirs(tmp_path)) == 4 * 2 + 1
    assert search.best_estimator_.n_steps_ == 4


@pytest.mark.slow
def test_parallel_search_does_not_oversubscribe(dataset, tmp_path):
    # joblib's loky workers export OMP_NUM_THREADS = cores // n_jobs, which torch
    # follows, so num_threads=None gives each of 2 workers at most half of the cores.
    grid = {"hole_weight": [0.0, 2.0]}
    search = GridSearchCV(tiny(checkpoint_dir=tmp_path), grid, cv=GroupKFold(2), n_jobs=2, refit=False)
    search.fit(dataset, groups=dataset.groups)
    assert np.isfinite(search.cv_results_["mean_test_score"]).all()
    runs = _run_dirs(tmp_path)
    assert len(runs) == 2 * 2
    limit = max(1, (os.cpu_count() or 1) // 2)
    for run in runs:
        last = json.loads((run / "state.json").read_text())["last"]
        assert json.loads((run / last / "config.json").read_text())["torch_threads"] <= limit
