"""Checks every shipped learned release, and every shipped interval, passes (imported by their test modules)."""

from __future__ import annotations

import subprocess
import sys
import time
from typing import Any

import numpy as np

from inpaintenv.data import SyntheticStreets
from inpaintenv.masks import get_protocol

#: Frame sizes a KITTI-style rig produces: the 352x1216 crop, the uncropped frames of each
#: recording day, and another rig's 1408x376.
FRAME_SHAPES = [(352, 1216), (375, 1242), (370, 1226), (376, 1241), (376, 1408)]


def check_full_frame(release: Any, shape: tuple[int, int] = (352, 1216)) -> None:
    """``release`` fills a full synthetic frame of ``shape``: positive, finite, measurements kept,
    within an order of magnitude of the speed goal."""
    gt = SyntheticStreets(n=1, seed=3, frame_shape=shape)[0]
    hole = get_protocol("rect-v1").mask(gt.shape, 0, 0)
    x = np.where(hole, np.nan, gt).astype(np.float32)
    release.predict(x)  # warm-up
    start = time.perf_counter()
    out = release.predict(x)
    seconds = time.perf_counter() - start
    assert out.shape == x.shape and np.isfinite(out).all() and (out[hole] > 0).all()
    measured = (gt > 0) & ~hole
    np.testing.assert_array_equal(out[measured], gt[measured])
    # The goal is 0.3 s on 2 idle cores (perf/bench_blend.py); a loaded CI
    # machine gets 10x that before this order-of-magnitude check fails.
    assert seconds < 3.0, f"predict took {seconds:.2f} s on a {shape} frame"


def check_beats_every_classical_method(release: Any, name: str, held_out: Any, seeds: list[int]) -> None:
    """Mean hole RMSE of ``release`` on ``held_out`` (rect-v1, ``seeds``) below that of every
    method of estimators.classical and the study's baselines, each scored as the benchmark
    scores it (the study's hole-only fills: 0 m as 0 m)."""
    from inpaintenv.benchmark.suites import CLASSICAL, STUDY_CLASSICAL
    from inpaintenv.evaluate import evaluate
    from inpaintenv.methods.registry import make_method, unfilled_policy

    def mean_hole_rmse(method: Any, unfilled: str = "error") -> float:
        rows = evaluate(method, held_out, "rect-v1", seeds, progress=False, unfilled=unfilled).rows
        return float(np.nanmean([r["hole_rmse"] for r in rows]))

    learned = mean_hole_rmse(release)
    classical = {m: mean_hole_rmse(make_method(m), unfilled_policy(m)) for m in CLASSICAL + STUDY_CLASSICAL}
    best = min(classical, key=classical.get)
    assert learned < classical[best], f"{name} {learned:.2f} m vs {best} {classical[best]:.2f} m"


def classes_in_fresh_processes(methods: list[str]) -> dict[str, str]:
    """The class name a fresh interpreter (as the CLI is) builds for each registry name: one
    interpreter per name, all started at once (each pays Python's and torch's start alone)."""
    code = ("import sys; from inpaintenv.methods.registry import make_method; "
            "print(type(make_method(sys.argv[1])).__name__)")
    procs = {m: subprocess.Popen([sys.executable, "-c", code, m], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                 text=True) for m in methods}
    try:
        classes = {}
        for method, proc in procs.items():
            out, err = proc.communicate(timeout=600)
            assert proc.returncode == 0, f"{method}: {err}"
            classes[method] = out.strip()
        return classes
    finally:
        for proc in procs.values():
            if proc.poll() is None:
                proc.kill()
                proc.wait()


def check_shipped_interval(wrapped: Any, x: np.ndarray, pred: np.ndarray) -> None:
    """A shipped interval around ``pred``, its base's prediction of ``x`` (NaN = hole): the
    prediction unchanged by ``return_std``, an interval finite, never inverted or empty in the
    hole, holding the prediction, non-negative, and of no width where ``x`` is given."""
    np.testing.assert_array_equal(wrapped.predict(x), pred)
    same, std = wrapped.predict(x, return_std=True)
    np.testing.assert_array_equal(same, pred)
    low, high = wrapped.predict_interval(x)
    hole = np.isnan(x)
    assert np.isfinite(low).all() and np.isfinite(high).all() and (std[hole] > 0).all() and (std[~hole] == 0).all()
    assert (low <= pred).all() and (pred <= high).all() and ((high - low)[hole] > 0).all()
    assert (low >= 0).all() and (low[~hole] == high[~hole]).all()
