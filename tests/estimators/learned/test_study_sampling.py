"""The study networks' training samples: flips and depth factors, the device sampling path
(run on the CPU, forced with sample_device="train"), persistent loader workers.

The GPU itself is not here (no GPU in CI): tests/gpu runs the device path on CUDA when
there is one. What this file pins is that the device path's code gives the loader path's
samples bit for bit, so on a GPU only the device's arithmetic can differ.
"""

from __future__ import annotations

import os

import numpy as np
import pytest
import torch

from estimators.learned import AutoencoderInpainter, PriorUNetInpainter, UNetInpainter
from estimators.learned._sampling import TrainingBatches, device_samples, draws_rectangles, rasterise
from estimators.learned._training_data import Augmentation, OcclusionFrames, epoch_order, sample_rng
from inpaintenv.data import ArrayDataset, as_dataset
from inpaintenv.exceptions import InvalidInputError, InvalidTypeError
from inpaintenv.masks import get_protocol
from inpaintenv.masks.rect import RectV1
from training_helpers import gradient_frames

#: A run small enough for a second on one core.
TINY = {"width": 4, "depth": 2, "crop": (32, 48), "batch_size": 2, "epochs": 2, "max_steps": 4, "random_state": 0,
        "num_threads": 1, "device": "cpu"}


def _frames(n: int = 6) -> np.ndarray:
    rng = np.random.default_rng(0)
    gt = (5.0 + 40.0 * rng.random((n, 40, 72))).astype(np.float32)
    gt[rng.random(gt.shape) < 0.3] = 0.0
    return gt


def _data(protocol: str = "rect-v1", augment: Augmentation | None = None, n: int = 6) -> OcclusionFrames:
    return OcclusionFrames(ArrayDataset(_frames(n)), get_protocol(protocol), (32, 64), seed=7, augment=augment)


def _same_weights(a, b) -> bool:
    sb = b.model_.state_dict()
    return all(torch.equal(v, sb[k]) for k, v in a.model_.state_dict().items())


# -- augmentation ------------------------------------------------------------------------
def test_without_augmentation_samples_are_those_of_before():
    # The sample as the loop drew it before augmentation existed: crop offset, then the mask.
    data, frames = _data(), _frames()
    for index in range(len(frames)):
        rng = sample_rng(7, 0, index)
        top, left = int(rng.integers(0, 40 - 32 + 1)), int(rng.integers(0, 72 - 64 + 1))
        hole = get_protocol("rect-v1").sample((32, 64), rng)
        gt, got_hole = data[index]
        assert torch.equal(gt, torch.from_numpy(frames[index, top:top + 32, left:left + 64]))
        assert torch.equal(got_hole, torch.from_numpy(hole))


def test_flips_mirror_the_same_crop_and_occlusion_about_half_the_time():
    plain, flipped = _data(n=40), _data(augment=Augmentation(flip=True), n=40)
    n_flipped = 0
    for index in range(40):
        (gt, hole), (fgt, fhole) = plain[index], flipped[index]
        is_flipped = flipped.draw(0, index).flip
        n_flipped += is_flipped
        want = (gt.flip(-1), hole.flip(-1)) if is_flipped else (gt, hole)
        assert torch.equal(fgt, want[0]) and torch.equal(fhole, want[1]), index
    assert 10 <= n_flipped <= 30  # p = 0.5 over 40 samples
    # Another epoch decides again.
    assert [flipped.draw(0, i).flip for i in range(40)] != [flipped.draw(1, i).flip for i in range(40)]


def test_depth_jitter_scales_the_depth_only_within_its_range():
    plain, scaled = _data(n=20), _data(augment=Augmentation(depth_jitter=1.5), n=20)
    factors = []
    for index in range(20):
        (gt, hole), (sgt, shole) = plain[index], scaled[index]
        factor = scaled.draw(0, index).factor
        assert factor.dtype == np.float32 and 1 / 1.5 <= factor <= 1.5
        assert torch.equal(sgt, gt * torch.tensor(factor)) and torch.equal(shole, hole)
        factors.append(float(factor))
    assert min(factors) < 1 < max(factors)


def test_flip_and_jitter_draw_from_one_stream_each_setting_leaves_the_other():
    both = Augmentation(flip=True, depth_jitter=1.5)
    flips = [Augmentation(flip=True).draw(3, 0, i)[0] for i in range(30)]
    factors = [Augmentation(depth_jitter=1.5).draw(3, 0, i)[1] for i in range(30)]
    assert [both.draw(3, 0, i) for i in range(30)] == list(zip(flips, factors))


# -- the device path, run on the CPU ---------------------------------------------------------
@pytest.mark.parametrize("shape", [(32, 64), (7, 5), (352, 1216)])
def test_rasterised_rectangles_are_the_protocols_masks(shape):
    protocol = get_protocol("rect-v1")
    rects = [protocol.rectangles(shape, np.random.default_rng(s)) for s in range(8)]
    masks = rasterise(rects, shape, torch.device("cpu"))
    for s in range(8):
        assert torch.equal(masks[s], torch.from_numpy(protocol.sample(shape, np.random.default_rng(s)))), s


def test_only_rect_v1_masks_are_rasterised():
    class Shifted(RectV1):  # a subclass that draws its own masks: sent from the CPU instead
        def sample(self, shape, rng):
            return np.roll(super().sample(shape, rng), 1, axis=1)

    assert draws_rectangles(get_protocol("rect-v1"))
    assert not draws_rectangles(Shifted()) and not draws_rectangles(get_protocol("freeform-v1"))


@pytest.mark.parametrize("protocol", ["rect-v1", "freeform-v1"])
@pytest.mark.parametrize("augment", [None, Augmentation(flip=True, depth_jitter=1.5)], ids=["plain", "augmented"])
def test_device_path_gives_the_loader_paths_samples_bit_for_bit(protocol, augment):
    data = _data(protocol, augment)
    order, epoch = epoch_order(len(data), 7, 2), 2
    frames = torch.from_numpy(_frames())[order]
    gt, hole = device_samples(data, frames, [epoch] * len(order), order.tolist())
    for k, index in enumerate(order):
        want_gt, want_hole = data[(epoch, int(index))]
        assert gt[k].dtype == want_gt.dtype and torch.equal(gt[k], want_gt), index
        assert torch.equal(hole[k], want_hole), index


@pytest.mark.parametrize("workers", [0, 2])
def test_both_paths_batch_alike_through_the_runs_loader(workers):
    data = _data(augment=Augmentation(flip=True))
    order = epoch_order(len(data), 7, 0)
    loader_path = TrainingBatches(data, 4, 0, torch.device("cpu"), on_device=False)
    device_path = TrainingBatches(data, 4, workers, torch.device("cpu"), on_device=True)
    for epoch in (0, 1):  # the second epoch through the same loader (persistent workers)
        a, b = list(loader_path.epoch(epoch, order)), list(device_path.epoch(epoch, order))
        assert len(a) == len(b) == 2
        for (ga, ha), (gb, hb) in zip(a, b):
            assert torch.equal(ga, gb) and torch.equal(ha, hb)
    device_path.close()
    with pytest.raises(RuntimeError, match="closed"):
        next(device_path.epoch(0, order))


@pytest.mark.parametrize("cls", [UNetInpainter, AutoencoderInpainter])
def test_fit_with_sampling_forced_onto_the_training_device_is_the_cpu_paths_fit(cls):
    params = {**TINY, "flip": True, "depth_jitter": 1.5}
    cpu = cls(**params).fit(gradient_frames())
    dev = cls(**params, sample_device="train").fit(gradient_frames())
    assert dev.history_["step_loss"] == cpu.history_["step_loss"] and _same_weights(dev, cpu)
    auto = cls(**params, sample_device="auto")  # "auto" is the loader path off CUDA
    assert not auto._sample_on_device(torch.device("cpu")) and auto._sample_on_device(torch.device("cuda"))


def test_augmented_fit_differs_from_the_plain_one():
    plain = UNetInpainter(**TINY).fit(gradient_frames())
    flipped = UNetInpainter(**TINY, flip=True).fit(gradient_frames())
    assert flipped.history_["step_loss"] != plain.history_["step_loss"]


# -- loader workers -------------------------------------------------------------------------
def test_two_loader_workers_give_the_weights_of_none():
    # Docs: a sample never depends on which worker loads it; fits on the CPU are bit-identical.
    params = {**TINY, "flip": True}
    none = UNetInpainter(**params).fit(gradient_frames())
    two = UNetInpainter(**params, num_workers=2).fit(gradient_frames())
    assert two.history_["step_loss"] == none.history_["step_loss"] and _same_weights(two, none)


class _PidFrames(OcclusionFrames):
    """Samples whose depth is the id of the process that loaded them."""

    def frame(self, index: int) -> np.ndarray:
        return np.full(tuple(self.frames.frame_shape), float(os.getpid()), dtype=np.float32)


def test_loader_workers_persist_across_epochs():
    data = _PidFrames(ArrayDataset(_frames(4)), get_protocol("rect-v1"), (32, 64), seed=0)
    batches = TrainingBatches(data, 1, 2, torch.device("cpu"), on_device=False)
    assert batches.loader.persistent_workers and not batches.loader.pin_memory
    pids = [{int(gt.flatten()[0]) for gt, _ in batches.epoch(e, range(4))} for e in range(3)]
    assert os.getpid() not in pids[0] and len(pids[0]) == 2
    assert pids[1] == pids[2] == pids[0]  # the same two processes every epoch
    batches.close()


def test_batches_are_pinned_only_for_cuda_and_workers_persist_only_if_any():
    data = _data()
    assert TrainingBatches(data, 2, 0, torch.device("cuda"), on_device=False).loader.pin_memory
    none = TrainingBatches(data, 2, 0, torch.device("cpu"), on_device=False).loader
    assert not none.pin_memory and not none.persistent_workers


# -- parameters -------------------------------------------------------------------------------
@pytest.mark.parametrize(("bad", "error", "message"), [
    ({"flip": 1}, InvalidTypeError, "flip must be True or False, got 1"),
    ({"depth_jitter": 1.0}, InvalidInputError, "depth_jitter must be a number in (1, 2] or None, got 1.0"),
    ({"depth_jitter": 3}, InvalidInputError, "depth_jitter must be a number in (1, 2] or None, got 3"),
    ({"sample_device": "gpu"}, InvalidInputError,
     "sample_device must be one of ('auto', 'cpu', 'train'), got 'gpu'"),
])
def test_bad_augmentation_or_sampling_parameter_is_one_clear_error(bad, error, message):
    with pytest.raises(error) as info:
        UNetInpainter(**TINY, **bad).fit(gradient_frames())
    assert str(info.value) == message


def test_prior_unet_keeps_its_own_flips_and_no_sampling_parameters():
    table = PriorUNetInpainter._parameter_constraints
    assert "sample_device" not in table and "depth_jitter" not in table and "flip" in table
    assert PriorUNetInpainter()._augmentation() is None


def test_run_folder_of_the_default_is_the_one_written_before_these_parameters():
    # Computed by the commit before flip/depth_jitter/sample_device existed (2ba8390).
    est = UNetInpainter(width=4, depth=2, crop=(32, 48), max_steps=2, random_state=0, checkpoint_dir="ck")
    data = as_dataset(gradient_frames())
    assert est._run_dir(data, 0).name == "UNetInpainter-379c65e947e577e5"
    assert est.set_params(sample_device="train")._run_dir(data, 0).name == "UNetInpainter-379c65e947e577e5"
    assert est.set_params(flip=True)._run_dir(data, 0).name != "UNetInpainter-379c65e947e577e5"
