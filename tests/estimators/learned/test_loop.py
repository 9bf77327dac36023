"""The one fitting loop (estimators/learned/_loop.py): every learned family trains through it;
its optimiser update, schedules, divergence check and epoch bookkeeping."""

from __future__ import annotations

import math
import sys

import pytest
import torch
from streets import streets as _streets

from estimators.learned import (
    AutoencoderInpainter,
    BlendInpainter,
    ContextBlendInpainter,
    MeanEnsembleInpainter,
    PriorUNetInpainter,
    ScanBlendInpainter,
    UNetInpainter,
)
from estimators.learned._loop import Constant, Cosine, OneCycle, Optimisation, fit_loop, new_progress, seeded
from inpaintenv.data import ArrayDataset, SyntheticStreets
from inpaintenv.exceptions import TrainingDivergedError

NEURAL = {"width": 4, "depth": 2, "batch_size": 2, "epochs": 1, "max_steps": 2, "random_state": 0, "num_threads": 1}
BLEND = {"width": 8, "layers": 1, "epochs": 1, "masks_per_frame": 1, "pixels_per_frame": 200, "batch_pixels": 128,
         "num_threads": 1}
PRIOR = {"width": 4, "levels": 1, "factor": 2, "batch_size": 2, "max_steps": 2, "random_state": 0, "num_threads": 1}
CONTEXT = {"n_context": 3, "context_widths": (4, 8), "width": 8, "layers": 1, "epochs": 1, "masks_per_frame": 1,
           "pixels_per_frame": 200, "batch_frames": 2, "batch_pixels": 64, "num_threads": 1}

#: Every learned family and a fit of it small enough for a test (the ensemble fits its members).
FAMILIES = {
    "unet": lambda: UNetInpainter(**NEURAL),
    "autoencoder": lambda: AutoencoderInpainter(**NEURAL),
    "prior-unet": lambda: PriorUNetInpainter(**PRIOR, arch="unet"),
    "prior-pixel": lambda: PriorUNetInpainter(**PRIOR, arch="pixel"),
    "blend": lambda: BlendInpainter(**BLEND),
    "context-blend": lambda: ContextBlendInpainter(**CONTEXT),
    "scan-blend": lambda: ScanBlendInpainter(**BLEND, near_distance=2.0),
    "ensemble": lambda: MeanEnsembleInpainter([("blend", BlendInpainter(**BLEND)),
                                               ("context", ContextBlendInpainter(**CONTEXT))]),
}


def _data(family: str):
    if family == "scan-blend":
        return SyntheticStreets(n=3, seed=1, frame_shape=(48, 160), input="scan")
    return ArrayDataset(_streets(n=4), groups=list("aabb"))


def _callers() -> set[str]:
    """``module.function`` of every frame on the current stack."""
    out, frame = set(), sys._getframe(1)
    while frame is not None:
        out.add(f"{frame.f_globals.get('__name__')}.{frame.f_code.co_name}")
        frame = frame.f_back
    return out


@pytest.mark.parametrize("family", sorted(FAMILIES))
def test_every_learned_family_trains_through_the_one_loop(family, monkeypatch):
    """Each optimiser step of every family's ``fit`` is taken by ``Optimisation.update`` inside ``fit_loop``."""
    steps: list[set[str]] = []
    real_step = torch.optim.Adam.step

    def watched(self, *args, **kwargs):
        steps.append(_callers())
        return real_step(self, *args, **kwargs)

    monkeypatch.setattr(torch.optim.Adam, "step", watched)
    FAMILIES[family]().fit(_data(family))
    assert steps, f"{family} took no optimiser step"
    for callers in steps:
        assert "estimators.learned._loop.fit_loop" in callers
        assert "estimators.learned._loop.update" in callers


def test_update_refuses_a_diverged_loss_without_stepping():
    net = seeded(lambda: torch.nn.Linear(2, 1), 0)
    before = {k: v.clone() for k, v in net.state_dict().items()}
    optimisation = Optimisation(net, 0.1)
    with pytest.raises(TrainingDivergedError, match="training loss became nan at update 1; lower lr"):
        optimisation.update(lambda: net(torch.ones(1, 2)).sum() * torch.tensor(float("nan")))
    assert all(torch.equal(before[k], v) for k, v in net.state_dict().items())
    assert optimisation.updates == 0


def test_seeded_builds_the_same_network_and_leaves_the_global_stream():
    state = torch.random.get_rng_state()
    a, b = (seeded(lambda: torch.nn.Linear(3, 2), 5) for _ in range(2))
    assert torch.equal(a.weight, b.weight)
    assert torch.equal(torch.random.get_rng_state(), state)


def test_one_cycle_is_torchs_one_cycle_schedule():
    def lrs(schedule_of):
        net = seeded(lambda: torch.nn.Linear(2, 1), 0)
        optimisation = Optimisation(net, 0.01, schedule=schedule_of())
        out = []
        for _ in range(100):
            out.append(optimisation.optimizer.param_groups[0]["lr"])
            optimisation.update(lambda: net(torch.ones(1, 2)).square().sum())
        return out

    net = seeded(lambda: torch.nn.Linear(2, 1), 0)
    reference = torch.optim.Adam(net.parameters(), lr=0.01)
    sched = torch.optim.lr_scheduler.OneCycleLR(reference, max_lr=0.01, total_steps=100, pct_start=0.05)
    expected = []
    for _ in range(100):
        expected.append(reference.param_groups[0]["lr"])
        reference.step()
        sched.step()
    assert lrs(lambda: OneCycle(0.01, 100)) == expected


def test_cosine_warms_up_decays_and_continues_from_adams_state():
    net = seeded(lambda: torch.nn.Linear(2, 1), 0)
    optimisation = Optimisation(net, 1.0, schedule=Cosine(1.0, 100))
    seen = []
    for _ in range(100):
        optimisation.update(lambda: net(torch.ones(1, 2)).square().sum())
        seen.append(optimisation.optimizer.param_groups[0]["lr"])
    assert seen[0] == pytest.approx(1 / 5)  # warm-up: 5 % of 100 updates
    assert seen[4] == pytest.approx(1.0)
    assert all(a >= b for a, b in zip(seen[4:], seen[5:]))  # then only down
    assert seen[-1] == pytest.approx(0.01)  # never below 1 %
    # A fresh Optimisation over the same Adam state (a resumed run) continues the schedule.
    again = Optimisation(net, 1.0, schedule=Cosine(1.0, 100))
    again.optimizer.load_state_dict(optimisation.optimizer.state_dict())
    again.schedule.before(again.optimizer)
    assert again.optimizer.param_groups[0]["lr"] == pytest.approx(0.01)
    assert isinstance(Optimisation(net, 1.0).schedule, Constant)


def test_fit_loop_counts_steps_records_epoch_means_and_stops_at_max_steps():
    calls = []

    def epoch_batches(epoch, done):
        return iter(range(done, 3))

    def step(batch):
        calls.append(batch)
        return float(batch + 1)

    ends = []
    progress = fit_loop(new_progress(), epoch_batches, step, epochs=2, steps_per_epoch=3, desc="test",
                        end_epoch=lambda p: ends.append(p["epoch"]) or False)
    assert calls == [0, 1, 2, 0, 1, 2]
    assert progress["step"] == 6 and progress["finished"] and ends == [0, 1]
    assert progress["history"]["epoch_loss"] == [2.0, 2.0]

    calls.clear()
    stopped = fit_loop(new_progress(), epoch_batches, step, epochs=2, steps_per_epoch=3, max_steps=4, desc="test")
    assert calls == [0, 1, 2, 0] and stopped["step"] == 4 and stopped["finished"]
    assert stopped["history"]["epoch_loss"] == [2.0, 1.0]  # the stopped epoch's mean over its steps
    assert not any(math.isnan(v) for v in stopped["history"]["epoch_loss"])


def test_fit_loop_resumes_mid_epoch_where_progress_stands():
    seen = []
    progress = new_progress()
    progress.update(epoch=1, batch=2, step=5)

    def epoch_batches(epoch, done):
        return ((epoch, b) for b in range(done, 3))

    fit_loop(progress, epoch_batches, lambda b: seen.append(b) or 0.0, epochs=2, steps_per_epoch=3, desc="test")
    assert seen == [(1, 2)] and progress["step"] == 6

