"""The FLOP helpers (perf/_unet_flops.py) and fits of perf/scaling_training.py (cheap: meta tensors, tiny arrays)."""

from __future__ import annotations

import numpy as np
import pytest
import torch


@pytest.fixture(scope="module")
def st(load_benchmark):
    return load_benchmark("scaling_training")


@pytest.fixture(scope="module")
def flops(load_benchmark):
    return load_benchmark("_unet_flops")


def test_count_flops_exact_on_one_convolution(flops):
    # 2 FLOPs per multiply-add, 9 taps × c_in per output value, bias not counted.
    conv = torch.nn.Conv2d(3, 5, 3, padding=1)
    x = torch.zeros(2, 3, 7, 11)
    assert flops.count_flops(lambda: conv(x)) == 2 * 9 * 3 * 5 * (2 * 7 * 11)


def test_count_flops_backward_of_one_convolution(flops):
    # Weight gradient and input gradient each cost one forward's FLOPs.
    conv = torch.nn.Conv2d(3, 5, 3, padding=1)
    x = torch.zeros(2, 3, 7, 11, requires_grad=True)
    forward = 2 * 9 * 3 * 5 * (2 * 7 * 11)
    assert flops.count_flops(lambda: conv(x).sum().backward()) == 3 * forward


@pytest.mark.parametrize("width,depth,h,w,skip", [(8, 2, 30, 50, True), (4, 3, 17, 40, False), (2, 1, 8, 8, True)])
def test_unet_formula_matches_counter(flops, width, depth, h, w, skip):
    counted = flops.forward_flops(width, depth, h, w, batch=3, skip=skip)
    assert counted == flops.unet_conv_flops(width, depth, h, w, batch=3, skip=skip)
    # Backward costs two forwards minus the first convolution's input gradient.
    first = 3 * 18 * width * (-(-h // 2**depth) * 2**depth) * (-(-w // 2**depth) * 2**depth)
    assert flops.train_flops(width, depth, h, w, batch=3, skip=skip) == 3 * counted - first


def test_params_match_real_model(flops):
    from estimators.learned.nets import UNet

    assert flops.n_params(8, 2) == sum(p.numel() for p in UNet(1, 8, 2).parameters())


def test_fits_recover_exact_lines(st):
    x = np.array([1.0, 2.0, 4.0, 8.0])
    line = st.fit_line(x, 0.5 + 3.0 * x)
    assert line["a"] == pytest.approx(0.5) and line["b"] == pytest.approx(3.0) and line["r2"] == pytest.approx(1.0)
    assert st.fit_line(x, 3.0 * x, through_origin=True)["b"] == pytest.approx(3.0)
    assert st.fit_power(x, 7.0 * x**2)["k"] == pytest.approx(2.0)
    with pytest.raises(ValueError, match="at least 2 points"):
        st.fit_line([1.0], [2.0])


def test_rejects_bad_arguments(st):
    with pytest.raises(SystemExit):
        st.main(["--repeats", "0"])
    with pytest.raises(SystemExit):
        st.main(["--gpu-util", "0.2", "1.5", "--from-json", "unused.json"])
