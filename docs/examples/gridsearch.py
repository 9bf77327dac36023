"""Cross-validated search of the U-Net loss weights, grouped by drive, end to end.

Runs on the built-in synthetic streets with a tiny configuration (small frames, narrow
net, few steps): it shows the mechanics, not good hyperparameters. 13 fits (4
candidates × 3 folds + refit); it took 443 s on 2026-11-25 on the project's shared
2-core machine while other jobs kept its load average near 8, far less on an idle one. For real work point ``data`` at ``KittiDepth(...)`` and use the
study's sizes.

    python docs/examples/gridsearch.py [--n-jobs 2] [--checkpoint-dir runs/gridsearch]

With ``--checkpoint-dir``, each (candidate, fold) trains in its own run directory named
by a hash of its parameters and its training frames; interrupting and re-running the
script resumes every unfinished fit from its last checkpoint.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from sklearn.model_selection import GridSearchCV, GroupKFold

from estimators.learned import UNetInpainter
from inpaintenv.data import SyntheticStreets


def main(argv: list[str] | None = None) -> GridSearchCV:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--frames", type=int, default=24)
    p.add_argument("--frame-shape", type=int, nargs=2, default=(64, 256), metavar=("H", "W"))
    p.add_argument("--n-jobs", type=int, default=1)
    p.add_argument("--checkpoint-dir", default=None)
    args = p.parse_args(argv)

    # 24 frames in 3 drives of 8: GroupKFold keeps every drive on one side of each split.
    data = SyntheticStreets(n=args.frames, seed=0, frame_shape=tuple(args.frame_shape), frames_per_drive=8)
    print(data)

    model = UNetInpainter(
        width=8, depth=3, crop=(64, 128), batch_size=4, epochs=2, random_state=0,
        # num_threads=None: torch's default in this process, and cores // n_jobs inside
        # joblib's workers (loky exports OMP_NUM_THREADS), so n_jobs never oversubscribes.
        checkpoint_dir=args.checkpoint_dir,
        # Each fit's progress: a bar on a terminal, one line per epoch in a log.
        verbose=1,
    )
    grid = {"hole_weight": [0.0, 2.0], "tv_weight": [0.0, 0.01]}
    # verbose=2: one line per (candidate, fold) when it ends, with its score and time.
    search = GridSearchCV(model, grid, cv=GroupKFold(n_splits=3), n_jobs=args.n_jobs, verbose=2)
    t0 = time.perf_counter()
    # ``score`` is minus the hole RMSE on rect-v1 holes (seed 0) of the held-out drive.
    search.fit(data, groups=data.groups)
    print(f"search took {time.perf_counter() - t0:.0f} s")

    res = search.cv_results_
    for i in np.argsort(res["rank_test_score"]):
        print(f"  hole RMSE {-res['mean_test_score'][i]:6.2f} ± {res['std_test_score'][i]:.2f} m   {res['params'][i]}")
    print("best:", search.best_params_)
    return search


if __name__ == "__main__":
    main()
