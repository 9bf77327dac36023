"""max_minutes: the wall-clock budget of a step-trained fit (a fake clock keeps it deterministic)."""

from __future__ import annotations

import json

import pytest
import torch

from estimators.learned import _budget
from estimators.learned import AutoencoderInpainter, PriorUNetInpainter, UNetInpainter
from inpaintenv.exceptions import InvalidInputError
from training_helpers import gradient_frames

RUN = {"batch_size": 1, "epochs": 3, "max_steps": 9, "random_state": 0, "num_threads": 1, "device": "cpu"}


_frames = gradient_frames


def _minute_per_call(monkeypatch) -> None:
    """A clock one minute further on at every call: the budget's start, then one call per step."""
    calls = iter(range(0, 10_000, 60))
    monkeypatch.setattr(_budget, "clock", lambda: float(next(calls)))


def test_budget_stops_after_the_step_it_ran_out_in_and_says_why(monkeypatch, tmp_path, capsys):
    _minute_per_call(monkeypatch)
    est = UNetInpainter(width=4, depth=2, max_minutes=2.5, checkpoint_dir=tmp_path, verbose=True, **RUN)
    est.fit(_frames())
    # 1, 2, then 3 minutes after steps 1, 2, 3: the third step spent the 2.5 minutes.
    assert est.n_steps_ == 3
    assert est.history_["budget_stop"] == {"step": 3, "minutes": 3.0, "max_minutes": 2.5}
    assert len(est.history_["step_loss"]) == 3
    assert "stopped on max_minutes=2.5 after step 3" in capsys.readouterr().err
    (run,) = tmp_path.iterdir()
    assert json.loads((run / "state.json").read_text())["last"].startswith("ckpt-00000003")


def test_resumed_run_gets_its_own_budget_and_ends_as_uninterrupted(monkeypatch, tmp_path):
    full = AutoencoderInpainter(width=4, depth=2, **RUN).fit(_frames())
    _minute_per_call(monkeypatch)
    first = AutoencoderInpainter(width=4, depth=2, max_minutes=4, checkpoint_dir=tmp_path, **RUN).fit(_frames())
    assert first.n_steps_ == 4  # mid-epoch 2
    resumed = AutoencoderInpainter(width=4, depth=2, max_minutes=None, checkpoint_dir=tmp_path, **RUN)
    resumed.fit(_frames())
    assert "budget_stop" not in resumed.history_
    assert resumed.n_steps_ == full.n_steps_ == 9
    assert resumed.history_ == full.history_
    for key, value in full.model_.state_dict().items():
        assert torch.equal(resumed.model_.state_dict()[key], value), key


@pytest.mark.parametrize("make", [
    lambda **kw: UNetInpainter(width=4, depth=2, **kw),
    lambda **kw: PriorUNetInpainter(arch="pixel", width=4, levels=1, factor=2, **kw),
])
def test_a_run_within_budget_is_bit_identical_to_no_budget(make):
    plain = make(**RUN).fit(_frames())
    budgeted = make(max_minutes=60.0, **RUN).fit(_frames())
    assert budgeted.n_steps_ == plain.n_steps_ == 9
    assert budgeted.history_ == plain.history_
    for key, value in plain.model_.state_dict().items():
        assert torch.equal(budgeted.model_.state_dict()[key], value), key


@pytest.mark.parametrize("bad", [0, -1.0, "5"])
def test_max_minutes_must_be_positive(bad):
    with pytest.raises((InvalidInputError, TypeError), match="max_minutes"):
        UNetInpainter(width=4, depth=2, max_minutes=bad, **RUN).fit(_frames())


def test_a_distributed_job_stops_on_the_budget_as_fit(monkeypatch):
    """A 1-process DDP job (gloo): its ranks agree on the stop, which lands after the same step as fit's."""
    import socket

    from estimators.learned.distributed import train_distributed

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    for key, value in {"RANK": "0", "LOCAL_RANK": "0", "WORLD_SIZE": "1", "MASTER_ADDR": "127.0.0.1",
                       "MASTER_PORT": str(port)}.items():
        monkeypatch.setenv(key, value)
    _minute_per_call(monkeypatch)
    ddp = train_distributed(UNetInpainter(width=4, depth=2, max_minutes=2.5, **RUN), _frames(), log=False)
    assert ddp.n_steps_ == 3 and ddp.history_["budget_stop"]["step"] == 3
