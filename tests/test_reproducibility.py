"""Bit-reproducible CPU runs from a seed, and the same numbers under every joblib backend.

Masks and synthetic frames are compared across processes (a subprocess with another
``PYTHONHASHSEED`` recomputes their hashes), evaluation rows across repeated runs,
backends and shardings, classical predictions across ``n_jobs`` and backends.
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from joblib import Parallel, delayed, parallel_config

from estimators.classical import IPBasicInpainter, NearestInpainter, TeleaInpainter
from estimators.classical._base import ClassicalInpainter
from inpaintenv.data import SyntheticStreets
from inpaintenv.evaluate import evaluate
from inpaintenv.report.results import EvaluationResult
from inpaintenv.masks import available_protocols, get_protocol

MASK_SHAPE = (64, 160)
FRAME_SHAPE = (48, 128)

# Recomputes the fingerprints in a fresh interpreter; prints them as JSON.
_CHILD = textwrap.dedent(
    """
    import hashlib, json
    import numpy as np
    from inpaintenv.data import SyntheticStreets
    from inpaintenv.masks import available_protocols, get_protocol

    def digest(a):
        return hashlib.sha256(np.ascontiguousarray(a).tobytes()).hexdigest()

    out = {p: digest(get_protocol(p).masks(%(mask_shape)r, 7, [0, 3, 1000])) for p in available_protocols()}
    ds = SyntheticStreets(n=3, seed=5, frame_shape=%(frame_shape)r, frames_per_drive=2)
    out["synthetic"] = digest(ds.load_batch([2, 0, 1]))
    print(json.dumps(out))
    """
) % {"mask_shape": MASK_SHAPE, "frame_shape": FRAME_SHAPE}


def digest(a: np.ndarray) -> str:
    return hashlib.sha256(np.ascontiguousarray(a).tobytes()).hexdigest()


def drop_timing(result: EvaluationResult) -> list[dict]:
    """Rows without the wall-clock column, in (seed, index) order."""
    rows = [{k: v for k, v in r.items() if k != "ms"} for r in result.rows]
    return sorted(rows, key=lambda r: (r["seed"], r["index"]))


def assert_same_rows(a: list[dict], b: list[dict]) -> None:
    assert len(a) == len(b)
    for ra, rb in zip(a, b):
        assert ra.keys() == rb.keys()
        for k in ra:
            # Bitwise equality; NaN (a hole without ground truth) equals NaN.
            same = ra[k] == rb[k] or (isinstance(ra[k], float) and np.isnan(ra[k]) and np.isnan(rb[k]))
            assert same, (k, ra[k], rb[k])


class PidInpainter(ClassicalInpainter):
    """Fills every frame with the id of the process that filled it (to see the backend)."""

    def __init__(self, *, keep_observed: bool = True, n_jobs: int | None = None):
        self.keep_observed = keep_observed
        self.n_jobs = n_jobs

    def _fill_frame(self, x: np.ndarray) -> np.ndarray:
        return np.full(x.shape, os.getpid(), dtype=np.float32)


@pytest.fixture(scope="module")
def frames() -> SyntheticStreets:
    return SyntheticStreets(n=6, seed=1, frame_shape=FRAME_SHAPE, frames_per_drive=3)


def test_masks_and_synthetic_frames_are_identical_in_another_process():
    env = dict(os.environ, PYTHONHASHSEED="12345")
    proc = subprocess.run(
        [sys.executable, "-c", _CHILD], capture_output=True, text=True, env=env, timeout=120, check=False
    )
    assert proc.returncode == 0, proc.stderr
    child = json.loads(proc.stdout)
    here = {p: digest(get_protocol(p).masks(MASK_SHAPE, 7, [0, 3, 1000])) for p in available_protocols()}
    here["synthetic"] = digest(
        SyntheticStreets(n=3, seed=5, frame_shape=FRAME_SHAPE, frames_per_drive=2).load_batch([2, 0, 1])
    )
    assert child == here


def test_synthetic_frames_do_not_depend_on_access_order():
    a = SyntheticStreets(n=4, seed=2, frame_shape=FRAME_SHAPE, frames_per_drive=2)
    b = SyntheticStreets(n=4, seed=2, frame_shape=FRAME_SHAPE, frames_per_drive=2)
    late = [b[i] for i in (3, 1, 2, 0)][::-1]  # reversed access order on a fresh instance
    for i, frame in zip((0, 2, 1, 3), late):
        assert digest(a[i]) == digest(frame)


def test_evaluation_rows_are_identical_run_to_run(frames):
    kwargs = {"protocol": "rect-v1", "seeds": (0, 3), "progress": False, "batch_size": 4}
    first = evaluate(NearestInpainter(), frames, **kwargs)
    second = evaluate(NearestInpainter(), frames, **kwargs)
    assert_same_rows(drop_timing(first), drop_timing(second))


@pytest.mark.parametrize("backend", ["threading", pytest.param("loky", marks=pytest.mark.slow)])
def test_evaluation_under_parallel_config_gives_the_same_rows(frames, backend):
    serial = evaluate(TeleaInpainter(n_jobs=1), frames, seeds=(0,), progress=False)
    # n_jobs=None lets the context decide: two workers of the chosen backend per batch.
    with parallel_config(backend=backend, n_jobs=2):
        parallel = evaluate(TeleaInpainter(), frames, seeds=(0,), progress=False)
    assert_same_rows(drop_timing(serial), drop_timing(parallel))


def test_sharded_evaluation_with_joblib_equals_one_run(frames):
    whole = evaluate(NearestInpainter(), frames, seeds=(0, 1), progress=False)
    shards = np.array_split(np.arange(len(frames)), 3)
    with parallel_config(backend="loky", n_jobs=2):
        parts = Parallel()(
            delayed(evaluate)(NearestInpainter(), frames, seeds=(0, 1), progress=False, indices=s.tolist())
            for s in shards
        )
    assert_same_rows(drop_timing(whole), drop_timing(EvaluationResult.concat(parts)))


@pytest.mark.parametrize("estimator", [NearestInpainter, TeleaInpainter, IPBasicInpainter], ids=lambda c: c.__name__)
def test_classical_predictions_do_not_depend_on_n_jobs_or_backend(frames, estimator):
    gt = frames.load_batch(range(5))
    x = gt.copy()
    x[get_protocol("rect-v1").masks(FRAME_SHAPE, 0, range(5))] = np.nan
    reference = estimator(n_jobs=1).predict(x)
    for n_jobs in (2, -1, None):
        np.testing.assert_array_equal(estimator(n_jobs=n_jobs).predict(x), reference)
    for backend in ("threading", "loky"):
        with parallel_config(backend=backend, n_jobs=2):
            np.testing.assert_array_equal(estimator().predict(x), reference)


@pytest.mark.parametrize("backend, other_process", [("threading", False), ("loky", True)])
def test_parallel_config_chooses_the_backend_of_classical_estimators(backend, other_process):
    x = np.full((4, 8, 8), np.nan, dtype=np.float32)
    with parallel_config(backend=backend, n_jobs=2):
        pids = set(np.unique(PidInpainter().predict(x)).astype(int).tolist())
    assert (os.getpid() not in pids) == other_process
    # Without a context, n_jobs=2 keeps the default: threads of this process.
    assert set(np.unique(PidInpainter(n_jobs=2).predict(x)).astype(int).tolist()) == {os.getpid()}
