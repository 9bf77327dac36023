"""DDP training on CPU with gloo, 2 processes: same losses as one process, rank-0 checkpoints.

Why the losses match: with a global batch of 4 split 2 + 2, rank r takes elements
r, r+2 of the single-process batch (same frames, same per-sample crops/masks, which are
seeded by (seed, epoch, index) alone). With every ground-truth pixel valid and
``hole_weight=0``, each loss term is a mean over the same number of pixels on every
rank, so the mean of the ranks' losses is the single-process loss of the whole batch,
and DDP's average of the ranks' gradients is its gradient. What remains is float
rounding (convolutions over batches of 2 vs 4 sum in a different order), hence a
tolerance rather than equality.
"""

from __future__ import annotations

import gc
import json
import os
import socket
import warnings
from pathlib import Path

import numpy as np
import pytest
import torch
import torch.multiprocessing as mp
from torch.nn.parallel import DistributedDataParallel

from estimators.learned.distributed import rank_order, train_distributed
from estimators.learned import distributed
from estimators.learned import UNetInpainter, load
from inpaintenv.data import ArrayDataset

WORLD = 2
PARAMS = {"width": 4, "depth": 2, "crop": (32, 64), "batch_size": 4, "epochs": 2, "max_steps": 3,
          "hole_weight": 0.0, "tv_weight": 0.01, "random_state": 0, "num_threads": 1, "amp": False}


def _frames() -> np.ndarray:
    # Every pixel valid (> 0): see the module docstring.
    rng = np.random.default_rng(0)
    return (5.0 + 40.0 * rng.random((8, 40, 72))).astype(np.float32)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _worker(rank: int, port: int, out: str) -> None:
    os.environ.update(RANK=str(rank), LOCAL_RANK=str(rank), WORLD_SIZE=str(WORLD),
                      MASTER_ADDR="127.0.0.1", MASTER_PORT=str(port))
    calls = Path(out) / f"writes-rank{rank}.txt"
    real = distributed.ckpt.write_run_checkpoint

    def recording(*args, **kwargs):
        with open(calls, "a") as f:
            f.write("write\n")
        return real(*args, **kwargs)

    distributed.ckpt.write_run_checkpoint = recording
    est = UNetInpainter(**PARAMS, checkpoint_dir=Path(out) / "ckpt", checkpoint_every=1)
    train_distributed(est, ArrayDataset(_frames()), log=False)
    (Path(out) / f"history-rank{rank}.json").write_text(json.dumps(est.history_))


def test_rank_order_splits_global_batches():
    order = np.arange(10)
    parts = [rank_order(order, 4, r, 2) for r in range(2)]
    assert parts[0].tolist() == [0, 2, 4, 6] and parts[1].tolist() == [1, 3, 5, 7]  # 8, 9 dropped


def test_outside_torchrun_is_a_clear_error(monkeypatch):
    for k in ("RANK", "WORLD_SIZE", "LOCAL_RANK", "MASTER_ADDR", "MASTER_PORT"):
        monkeypatch.delenv(k, raising=False)
    with pytest.raises(RuntimeError, match="torchrun"):
        train_distributed(UNetInpainter(**PARAMS), _frames())


@pytest.mark.slow
@pytest.mark.timeout(120)
def test_two_gloo_processes_match_one_process(tmp_path):
    mp.spawn(_worker, args=(_free_port(), str(tmp_path)), nprocs=WORLD, join=True)

    single = UNetInpainter(**PARAMS).fit(_frames())
    h0 = json.loads((tmp_path / "history-rank0.json").read_text())
    h1 = json.loads((tmp_path / "history-rank1.json").read_text())
    assert h0 == h1  # every rank logs the all-reduced loss
    assert len(h0["step_loss"]) == len(single.history_["step_loss"]) == 3
    np.testing.assert_allclose(h0["step_loss"], single.history_["step_loss"], rtol=1e-4)

    # Only rank 0 wrote checkpoints (one per step), and the run loads as a model.
    assert (tmp_path / "writes-rank0.txt").read_text().count("write") >= 3
    assert not (tmp_path / "writes-rank1.txt").exists()
    (run,) = (tmp_path / "ckpt").iterdir()
    assert run.name.startswith("ddp2-UNetInpainter-")
    model = load(run)
    x = _frames()[:1].copy()
    x[:, 10:20, 10:40] = np.nan
    # Weights agree to rounding, amplified a little by Adam (it divides each gradient by
    # its own magnitude, so near-zero gradients' rounding moves weights by up to ~lr).
    np.testing.assert_allclose(model.predict(x), single.predict(x), rtol=0, atol=1e-2)  # metres


@pytest.fixture
def one_process_group(monkeypatch):
    """The torchrun environment of a 1-process job on a free localhost port."""
    monkeypatch.setenv("RANK", "0")
    monkeypatch.setenv("LOCAL_RANK", "0")
    monkeypatch.setenv("WORLD_SIZE", "1")
    monkeypatch.setenv("MASTER_ADDR", "127.0.0.1")
    monkeypatch.setenv("MASTER_PORT", str(_free_port()))


def test_world_of_one_is_bit_identical_to_fit(one_process_group):
    # 8 frames / batch 4: no dropped batch, so the same steps as fit, and DDP over one
    # process averages nothing.
    params = {**PARAMS, "hole_weight": 2.0}
    ddp = train_distributed(UNetInpainter(**params), _frames(), log=False)
    single = UNetInpainter(**params).fit(_frames())
    assert ddp.history_ == single.history_
    for k, v in single.model_.state_dict().items():
        assert np.array_equal(ddp.model_.state_dict()[k].numpy(), v.numpy()), k


def _drives(n_drives: int = 4) -> ArrayDataset:
    return ArrayDataset(_frames(), groups=[f"drive{i % n_drives}" for i in range(len(_frames()))])


def test_world_of_one_validates_as_fit(one_process_group):
    # fit's loop: the held-out drives are scored each epoch and the best epoch is kept.
    params = {**PARAMS, "batch_size": 2, "max_steps": None, "validation_fraction": 0.25}
    ddp = train_distributed(UNetInpainter(**params), _drives(), log=False)
    single = UNetInpainter(**params).fit(_drives())
    assert len(ddp.history_["val_hole_rmse"]) == 2
    assert ddp.history_ == single.history_
    for k, v in single.model_.state_dict().items():
        assert torch.equal(ddp.model_.state_dict()[k], v), k


def test_world_of_one_warm_starts_as_fit(one_process_group):
    first = train_distributed(UNetInpainter(**PARAMS), _frames(), log=False)
    before = {k: v.clone() for k, v in first.model_.state_dict().items()}
    again = UNetInpainter(**PARAMS, warm_start=True)
    again.model_ = first.model_
    train_distributed(again, _frames(), log=False)
    single = UNetInpainter(**PARAMS, warm_start=True)
    single.model_ = UNetInpainter(**PARAMS).fit(_frames()).model_
    single.fit(_frames())
    assert any(not torch.equal(before[k], v) for k, v in again.model_.state_dict().items())
    for k, v in single.model_.state_dict().items():
        assert torch.equal(again.model_.state_dict()[k], v), k


@pytest.mark.parametrize(("est", "err", "match"), [
    (UNetInpainter(**{**PARAMS, "batch_size": 16}), ValueError, "fewer than one global batch"),
    ("not an estimator", TypeError, "UNetInpainter or AutoencoderInpainter"),
])
def test_bad_configurations_are_clear_errors(one_process_group, est, err, match):
    with pytest.raises(err, match=match):
        train_distributed(est, _frames(), log=False)


def test_prior_unet_is_refused():
    from estimators.learned import PriorUNetInpainter

    with pytest.raises(TypeError, match="PriorUNetInpainter"):
        train_distributed(PriorUNetInpainter(), _frames())


def test_distributed_run_resumes_after_a_crash(one_process_group, tmp_path, monkeypatch):
    from estimators.learned import _neural as neural

    params = {**PARAMS, "max_steps": 3, "checkpoint_every": 1}
    full = train_distributed(UNetInpainter(**params, checkpoint_dir=tmp_path / "a"), _frames(), log=False)

    orig, calls = neural._NeuralInpainter._train_step, {"n": 0}

    def crash_after_two(self, *a):
        if calls["n"] == 2:
            raise KeyboardInterrupt("simulated crash")
        calls["n"] += 1
        return orig(self, *a)

    with monkeypatch.context() as m:
        m.setattr(neural._NeuralInpainter, "_train_step", crash_after_two)
        with pytest.raises(KeyboardInterrupt):
            train_distributed(UNetInpainter(**params, checkpoint_dir=tmp_path / "b"), _frames(), log=False)
    (run,) = (tmp_path / "b").iterdir()
    assert json.loads((run / "state.json").read_text())["last"].startswith("ckpt-00000002")
    resumed = train_distributed(UNetInpainter(**params, checkpoint_dir=tmp_path / "b"), _frames(), log=False)
    assert resumed.n_steps_ == full.n_steps_ == 3
    assert resumed.history_ == full.history_
    for k, v in full.model_.state_dict().items():
        assert np.array_equal(resumed.model_.state_dict()[k].numpy(), v.numpy()), k


def test_group_is_left_with_no_ddp_wrapper_alive(one_process_group, monkeypatch):
    # A DDP wrapper still alive when the group is destroyed (its reducer sits in reference
    # cycles) made rank 1 abort at interpreter exit now and then; gc is off to make the
    # cycle certain rather than up to the collector's timing.
    real_destroy = distributed.dist.destroy_process_group
    alive = []

    def counting_destroy(*args, **kwargs):
        with warnings.catch_warnings():  # isinstance on deprecated torch objects warns
            warnings.simplefilter("ignore", FutureWarning)
            alive.append(sum(isinstance(o, DistributedDataParallel) for o in gc.get_objects()))
        return real_destroy(*args, **kwargs)

    monkeypatch.setattr(distributed.dist, "destroy_process_group", counting_destroy)
    gc.disable()
    try:
        train_distributed(UNetInpainter(**PARAMS), _frames(), log=False)
    finally:
        gc.enable()
    assert alive == [0]
