"""Shapes, sizes and structure of the U-Net / autoencoder modules."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from estimators.learned.nets import UNet, UNetDecoder, UNetEncoder, pad_to_multiple
from estimators.learned import UNetInpainter


@pytest.fixture(autouse=True)
def _one_thread():
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(before)


@pytest.mark.parametrize("skip", [True, False])
@pytest.mark.parametrize("size", [(352, 1216), (375, 1242), (37, 53), (1, 1), (9, 2)])
def test_any_input_size_gives_same_output_size(skip, size):
    net = UNet(in_channels=1, width=2, depth=4, skip=skip)
    with torch.inference_mode():
        out = net(torch.rand(1, 1, *size))
    assert out.shape == (1, 1, *size)
    assert torch.isfinite(out).all()


@pytest.mark.parametrize("in_channels", [1, 3])
def test_in_channels_and_batch(in_channels):
    net = UNet(in_channels=in_channels, width=4, depth=2)
    assert net(torch.rand(3, in_channels, 20, 30)).shape == (3, 1, 20, 30)
    with pytest.raises(ValueError, match=rf"\(N, {in_channels}, H, W\)"):
        net(torch.rand(3, in_channels + 1, 20, 30))


def test_encoder_levels_and_widths():
    enc = UNetEncoder(in_channels=1, width=8, depth=3)
    feats = enc(torch.rand(2, 1, 32, 64))
    assert [f.shape[1] for f in feats] == [8, 16, 32, 64]
    assert [tuple(f.shape[-2:]) for f in feats] == [(32, 64), (16, 32), (8, 16), (4, 8)]
    # The study's block: conv -> GroupNorm -> ReLU, twice.
    kinds = [type(m).__name__ for m in enc.blocks[0]]
    assert kinds == ["Conv2d", "GroupNorm", "ReLU", "Conv2d", "GroupNorm", "ReLU"]


def test_autoencoder_has_no_skip_inputs():
    unet, ae = UNetDecoder(8, 3, skip=True), UNetDecoder(8, 3, skip=False)
    # Level-0 block of the U-Net sees upsampled (16) + skip (8) channels, the AE only 16.
    assert unet.blocks[0][0].in_channels == 24
    assert ae.blocks[0][0].in_channels == 16
    # Same encoder in both: weights are interchangeable (warm start).
    a, b = UNet(1, 8, 3, skip=True), UNet(1, 8, 3, skip=False)
    assert a.encoder.state_dict().keys() == b.encoder.state_dict().keys()
    assert all(a.encoder.state_dict()[k].shape == v.shape for k, v in b.encoder.state_dict().items())


def test_padding_is_cropped_back_not_leaked():
    x = torch.arange(15.0).reshape(1, 1, 3, 5)
    p = pad_to_multiple(x, 4)
    assert p.shape == (1, 1, 4, 8)
    assert torch.equal(p[..., :3, :5], x)
    assert torch.equal(p[..., 3, :5], x[..., 2, :])  # replicate
    assert pad_to_multiple(x, 4, "zeros")[..., 3:, :].abs().sum() == 0
    with pytest.raises(ValueError, match="pad mode"):
        pad_to_multiple(x, 4, "reflect")


@pytest.mark.parametrize("bad", [{"width": 0}, {"depth": 0}, {"width": 2.5}])
def test_bad_architecture_is_refused_by_the_estimator_before_the_network(bad):
    # The networks take checked sizes: the estimator's table names the parameter and value.
    with pytest.raises(ValueError, match=rf"^{next(iter(bad))} must be an integer >= 1, got {next(iter(bad.values()))}$"):
        UNetInpainter(**bad, random_state=0).fit(np.ones((2, 16, 16), np.float32))
