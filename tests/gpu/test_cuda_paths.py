"""The CUDA paths of the U-Net training: bf16 autocast, a 1-process DDP job, resume, samples
(through the loader and assembled on the device, ``sample_device="train"``).

Every test here is marked ``gpu`` and runs on the ``gpu_device`` fixture (tests/conftest.py):
``cuda`` on a machine with a GPU, the CPU elsewhere or when ``INPAINTENV_GPU_TESTS_ON_CPU=1``
(so the main suite runs this code path on every machine).

What is compared exactly and what within a tolerance follows the docs: two fits with the
same seed give identical weights on the CPU (docs/reference/neural.md), so on the CPU
every comparison is exact. On CUDA the docs claim no bit-identity (cuDNN may pick
non-deterministic kernels, convolutions may run in TF32), so there the tests compare
within tolerances that a different sample, seed or lost optimiser state would exceed by
far. The training samples themselves (crops, occlusions, visiting order) are drawn on the
CPU from ``(seed, epoch, index)`` and must be identical on every device.
"""

from __future__ import annotations

import json
import math
import os
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

from estimators.learned.distributed import train_distributed
from estimators.learned import distributed
from estimators.learned._sampling import TrainingBatches
from estimators.learned._training import Augmentation, OcclusionFrames, epoch_order, make_loader
from estimators.learned.losses import inpainting_loss
from estimators.learned.nets import UNet
from estimators.learned import UNetInpainter, load
from inpaintenv.data import ArrayDataset
from inpaintenv.masks import get_protocol

pytestmark = pytest.mark.gpu

REPO = Path(__file__).resolve().parents[2]
#: A network and run small enough for seconds on two CPU cores.
TINY = {"width": 4, "depth": 2, "crop": (32, 64), "batch_size": 4, "epochs": 2, "max_steps": 3,
        "random_state": 0, "num_threads": 1}


def _frames(n: int = 8) -> np.ndarray:
    """``n`` 40×72 frames, 30 % of pixels unmeasured (0), 5-45 m elsewhere."""
    rng = np.random.default_rng(0)
    gt = (5.0 + 40.0 * rng.random((n, 40, 72))).astype(np.float32)
    gt[rng.random(gt.shape) < 0.3] = 0.0
    return gt


def _exact(device: torch.device) -> bool:
    """Whether the docs promise bit-identical repeats on ``device`` (the CPU only)."""
    return device.type == "cpu"


def _assert_same_weights(a: UNetInpainter, b: UNetInpainter, exact: bool) -> None:
    """Equal weights; within rounding, only the same seed's: Adam moves every weight by up to
    ``lr`` (1e-3) a step whatever its gradient's size, so a gradient at rounding level moves
    it either way by up to 3e-3 in 3 steps. The losses compare the training itself."""
    for name, value in a.model_.state_dict().items():
        other = b.model_.state_dict()[name]
        if exact:
            assert torch.equal(value, other), name
        else:
            torch.testing.assert_close(value, other, rtol=0, atol=1e-2, msg=lambda m: f"{name}: {m}")


def _assert_same_losses(a: list[float], b: list[float], exact: bool) -> None:
    assert len(a) == len(b)
    if exact:
        assert a == b
    else:
        np.testing.assert_allclose(a, b, rtol=5e-3)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


# -- mixed precision ------------------------------------------------------------------
@pytest.mark.timeout(120)
def test_bf16_autocast_forward_and_backward(gpu_device):
    torch.manual_seed(0)
    model = UNet(1, 8, 2).to(gpu_device)
    gt = torch.from_numpy(_frames(2)[:, :32, :64]).to(gpu_device)
    hole = torch.zeros_like(gt, dtype=torch.bool)
    hole[:, 8:24, 16:48] = True
    x = (torch.where(hole, torch.zeros_like(gt), gt) / 80.0).unsqueeze(1)
    with torch.no_grad():
        reference = model(x)[:, 0]
    with torch.autocast(gpu_device.type, dtype=torch.bfloat16):
        pred = model(x)[:, 0]
    assert pred.dtype == torch.bfloat16  # the convolutions ran in bf16
    # bf16 keeps 8 bits of mantissa: the forward agrees with fp32 to a few per cent.
    torch.testing.assert_close(pred.float(), reference, rtol=0, atol=0.05 * float(reference.abs().max()))
    loss = inpainting_loss(pred.float(), gt / 80.0, gt > 0, hole, 2.0, 0.01)
    loss.backward()
    assert torch.isfinite(loss)
    for name, p in model.named_parameters():
        assert p.grad is not None and p.grad.dtype == torch.float32, name  # fp32 master weights
        assert torch.isfinite(p.grad).all(), name
    assert any(float(p.grad.abs().sum()) > 0 for p in model.parameters())


@pytest.mark.timeout(120)
def test_estimator_trains_and_predicts_under_autocast(gpu_device):
    # amp=True is autocast on CUDA (bf16 on a GPU that has it); on the CPU "cpu-bf16" asks for the same.
    amp = True if gpu_device.type == "cuda" else "cpu-bf16"
    est = UNetInpainter(**TINY, device=str(gpu_device), amp=amp).fit(_frames())
    assert est.n_steps_ == 3 and all(math.isfinite(v) for v in est.history_["step_loss"])
    x = _frames(2)
    x[:, 10:30, 20:60] = np.nan
    pred = est.predict(x)
    assert pred.shape == x.shape and np.isfinite(pred).all()
    np.testing.assert_array_equal(pred[x > 0], x[x > 0])  # measured pixels kept


# -- multi-process training, world size 1 -----------------------------------------------
@pytest.fixture
def one_process_job(monkeypatch):
    """The torchrun environment of a 1-process job on a free localhost port."""
    for key, value in {"RANK": "0", "LOCAL_RANK": "0", "WORLD_SIZE": "1", "MASTER_ADDR": "127.0.0.1",
                       "MASTER_PORT": str(_free_port())}.items():
        monkeypatch.setenv(key, value)


@pytest.mark.timeout(180)
def test_one_process_ddp_job_on_the_device(gpu_device, one_process_job, monkeypatch):
    backends = []
    real_init = distributed.dist.init_process_group

    def recording_init(*args, **kwargs):
        backends.append(kwargs.get("backend", args[0] if args else None))
        return real_init(*args, **kwargs)

    monkeypatch.setattr(distributed.dist, "init_process_group", recording_init)
    params = {**TINY, "device": str(gpu_device), "amp": False}
    ddp = train_distributed(UNetInpainter(**params), _frames(), log=False)
    assert backends == ["nccl" if gpu_device.type == "cuda" else "gloo"]
    assert not distributed.dist.is_initialized()  # the group is left after the job
    # 8 frames in batches of 4 drop nothing, and DDP over one process averages nothing:
    # the steps of fit, on the same device.
    single = UNetInpainter(**params).fit(_frames())
    assert ddp.n_steps_ == single.n_steps_ == 3
    _assert_same_losses(ddp.history_["step_loss"], single.history_["step_loss"], _exact(gpu_device))
    _assert_same_weights(ddp, single, _exact(gpu_device))


@pytest.mark.timeout(240)
def test_torchrun_one_process_command_line(gpu_device, tmp_path):
    # The command of docs/reference/distributed.md with one process: device "auto" of the
    # preset picks CUDA (nccl, cuda:LOCAL_RANK) on a GPU; hiding the GPUs forces the CPU.
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}
    if gpu_device.type == "cpu":
        env["CUDA_VISIBLE_DEVICES"] = ""
    cmd = [sys.executable, "-m", "torch.distributed.run", "--nproc_per_node=1", f"--master_port={_free_port()}",
           "-m", "estimators.learned.distributed", "--preset", "study-unet-tv", "--out", str(tmp_path / "out"),
           "--n-frames", "2", "--batch-size", "2", "--max-steps", "1", "--num-threads", "1"]
    done = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=200)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-4000:]
    assert "[rank 0/1] done: 1 steps" in done.stdout
    model = load(tmp_path / "out" / "model")
    assert model.n_steps_ == 1


# -- checkpoints -----------------------------------------------------------------------
class Crash(Exception):
    """Raised by :class:`CountingFrames` to interrupt a fit."""


class CountingFrames(ArrayDataset):
    """Frames that count the loads of training samples and can crash after ``crash_after``.

    The same class with and without a crash: the run directory's hash names the class.
    """

    def __init__(self, frames: np.ndarray, crash_after: int | None = None):
        super().__init__(frames)
        self.crash_after = crash_after
        self.loads = 0

    def checked_frame(self, index: int, name: str) -> np.ndarray:
        # Training reads every sample through checked_frame; the data fingerprint does not.
        if self.crash_after is not None and self.loads >= self.crash_after:
            raise Crash(f"simulated crash before sample {self.loads}")
        self.loads += 1
        return super().checked_frame(index, name)


@pytest.mark.timeout(180)
def test_checkpoint_resume_on_the_device(gpu_device, tmp_path):
    params = {**TINY, "device": str(gpu_device), "checkpoint_every": 1}
    full = UNetInpainter(**params, checkpoint_dir=tmp_path / "full").fit(CountingFrames(_frames()))

    # Batches of 4: the crash comes while loading step 3's batch, after step 2's checkpoint.
    with pytest.raises(Crash):
        UNetInpainter(**params, checkpoint_dir=tmp_path / "cut").fit(CountingFrames(_frames(), crash_after=8))
    frames = CountingFrames(_frames())
    resumed = UNetInpainter(**params, checkpoint_dir=tmp_path / "cut").fit(frames)
    assert frames.loads == 4  # one batch: steps 1-2 came from the checkpoint written on the device
    assert resumed.n_steps_ == full.n_steps_ == 3
    _assert_same_losses(resumed.history_["step_loss"], full.history_["step_loss"], _exact(gpu_device))
    _assert_same_weights(resumed, full, _exact(gpu_device))
    # The run directory loads on the CPU and predicts as the fitted model does.
    loaded = load(resumed.run_dir_)
    x = _frames(1)
    x[:, 10:30, 20:60] = np.nan
    np.testing.assert_allclose(loaded.predict(x), resumed.set_params(device="cpu").predict(x), rtol=0, atol=1e-4)


# -- determinism -----------------------------------------------------------------------
@pytest.mark.timeout(120)
def test_same_seed_same_fit(gpu_device):
    # Docs: identical weights on the CPU; on CUDA no such claim, so agreement within rounding.
    a = UNetInpainter(**TINY, device=str(gpu_device), amp=False).fit(_frames())
    b = UNetInpainter(**TINY, device=str(gpu_device), amp=False).fit(_frames())
    _assert_same_losses(a.history_["step_loss"], b.history_["step_loss"], _exact(gpu_device))
    _assert_same_weights(a, b, _exact(gpu_device))
    other = UNetInpainter(**{**TINY, "random_state": 1}, device=str(gpu_device), amp=False).fit(_frames())
    assert other.history_["step_loss"][0] != pytest.approx(a.history_["step_loss"][0], rel=5e-3)


# -- training samples across devices -----------------------------------------------------
def _samples(data: OcclusionFrames, order: np.ndarray, device: torch.device, workers: int) -> list[torch.Tensor]:
    """Every batch of the training loader as the device path sees it, copied back to the CPU."""
    out = []
    pin = device.type == "cuda"  # what fit asks of the loader on CUDA
    for gt, hole in make_loader(data, order, 4, workers, pin):
        if pin:
            assert gt.is_pinned() and hole.is_pinned()
        out += [gt.to(device, non_blocking=True).cpu(), hole.to(device, non_blocking=True).cpu()]
    return out


@pytest.mark.timeout(120)
def test_same_seed_same_training_samples_on_cpu_and_device(gpu_device):
    data = OcclusionFrames(ArrayDataset(_frames()), get_protocol("rect-v1"), (32, 64), seed=7)
    order = epoch_order(len(data), 7, 0)
    on_cpu = _samples(data, order, torch.device("cpu"), workers=0)
    on_device = _samples(data, order, gpu_device, workers=2)
    assert len(on_cpu) == len(on_device) == 4
    for a, b in zip(on_cpu, on_device):
        assert a.dtype == b.dtype and torch.equal(a, b)
    data.epoch = 1  # not vacuous: another epoch draws other crops and occlusions
    assert not all(torch.equal(a, b) for a, b in zip(on_cpu, _samples(data, order, gpu_device, workers=0)))


@pytest.mark.timeout(120)
def test_first_step_loss_agrees_on_cpu_and_device(gpu_device):
    # Same seed: same initial weights (drawn on the CPU) and the same first batch, so the
    # first loss differs only by the device's arithmetic (TF32 convolutions on CUDA).
    params = {**TINY, "max_steps": 1, "amp": False}
    cpu = UNetInpainter(**params, device="cpu").fit(_frames())
    dev = UNetInpainter(**params, device=str(gpu_device)).fit(_frames())
    _assert_same_losses(cpu.history_["step_loss"], dev.history_["step_loss"], _exact(gpu_device))


@pytest.mark.timeout(120)
def test_samples_made_on_the_device_are_the_loaders(gpu_device):
    # sample_device="train": whole frames through pinned memory, then crop, rect-v1 rectangles,
    # flips and depth factors on the device, from the draws the loader path makes on the CPU.
    data = OcclusionFrames(ArrayDataset(_frames()), get_protocol("rect-v1"), (32, 64), seed=7,
                           augment=Augmentation(flip=True, depth_jitter=1.5))
    order = epoch_order(len(data), 7, 0)
    loader_path = TrainingBatches(data, 4, 2, gpu_device, on_device=False)
    device_path = TrainingBatches(data, 4, 2, gpu_device, on_device=True)
    assert loader_path.loader.pin_memory == (gpu_device.type == "cuda")
    for epoch in (0, 1):  # the second epoch from the same persistent workers
        a, b = list(loader_path.epoch(epoch, order)), list(device_path.epoch(epoch, order))
        assert len(a) == len(b) == 2
        for (ga, ha), (gb, hb) in zip(a, b):
            assert ga.device.type == "cpu" and gb.device.type == gpu_device.type
            if gpu_device.type == "cuda":
                assert ga.is_pinned() and ha.is_pinned()
            assert torch.equal(ga, gb.cpu()) and torch.equal(ha, hb.cpu())
    loader_path.close()
    device_path.close()


@pytest.mark.timeout(180)
def test_fit_sampling_on_the_device_is_the_loader_paths_fit(gpu_device):
    # The same samples: on the CPU identical weights; on CUDA within the rounding of its kernels.
    params = {**TINY, "device": str(gpu_device), "amp": False, "flip": True}
    loader_path = UNetInpainter(**params).fit(_frames())
    device_path = UNetInpainter(**params, sample_device="train").fit(_frames())
    _assert_same_losses(device_path.history_["step_loss"], loader_path.history_["step_loss"], _exact(gpu_device))
    _assert_same_weights(device_path, loader_path, _exact(gpu_device))


def test_forced_cpu_mode_is_reported(gpu_device):
    # The quick GPU check relies on the variable: forced mode must really be the CPU.
    if os.environ.get("INPAINTENV_GPU_TESTS_ON_CPU") == "1" or not torch.cuda.is_available():
        assert gpu_device.type == "cpu"
    else:
        assert gpu_device.type == "cuda" and torch.cuda.is_available()
    print(json.dumps({"gpu_device": str(gpu_device)}))
