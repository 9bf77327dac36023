"""scan_lodo.py's command lines: every command's --help, lodo's --shrinks, the probe's training inputs."""

from __future__ import annotations

import numpy as np
import pytest


@pytest.fixture(scope="module")
def scan_lodo(load_experiment):
    return load_experiment("scan_lodo")


@pytest.mark.parametrize("command", ["classical", "lodo", "release", "official", "time", "density", "holes"])
def test_every_command_prints_its_help(scan_lodo, command, capsys):
    with pytest.raises(SystemExit) as info:
        scan_lodo.COMMANDS[command](["--help"])
    assert info.value.code == 0
    out = capsys.readouterr().out
    assert "--per-drive" in out
    if command in ("lodo", "density"):
        assert "50 % points" in out  # the density labels, their % printed as it is


def test_shrinks_are_copies_of_one_fitted_model_each_at_its_shrink(scan_lodo):
    from estimators.learned import SparseResidualInpainter
    from inpaintenv.data import SyntheticStreets

    est = SparseResidualInpainter(epochs=1, pixels_per_frame=100, num_threads=1).fit(
        SyntheticStreets(n=2, seed=1, frame_shape=(48, 96), frames_per_drive=2, input="scan"))
    out = scan_lodo.shrunk(est, scan_lodo.numbers_option("1,0.75,0.5"))
    assert list(out) == ["ours shrink 1", "ours shrink 0.75", "ours shrink 0.5"]
    assert [m.shrink for m in out.values()] == [1.0, 0.75, 0.5] and est.shrink == 1.0
    assert all(m.model_ is est.model_ for m in out.values())  # one fit, the weights shared


def test_the_probe_with_hole_seeds_also_trains_on_rect_v1_holes_cut_into_the_scan(scan_lodo):
    from inpaintenv.masks import get_protocol

    scan = np.full((48, 96), np.nan, np.float32)
    scan[::4] = 10.0  # a line every 4 rows, as a scan's
    scan = np.nan_to_num(scan, nan=0.0)
    inputs = scan_lodo.ResidualProbe(hole_seeds=(100, 101))._inputs(scan, 3)
    assert len(inputs) == 3 and np.array_equal(np.isnan(inputs[0]), scan == 0)  # the scan as it is first
    for x, seed in zip(inputs[1:], (100, 101)):
        hole = get_protocol("rect-v1").mask(scan.shape, seed, 3)
        assert np.isnan(x[hole]).all() and np.array_equal(np.isnan(x), (scan == 0) | hole)
    assert len(scan_lodo.ResidualProbe()._inputs(scan, 3)) == 1


@pytest.mark.parametrize("value", ["abc", "0.5,", "1,nan", "2"])
def test_shrinks_that_are_not_numbers_or_that_the_estimator_refuses_stop_before_any_fit(scan_lodo, capsys,
                                                                                       monkeypatch, value):
    monkeypatch.setattr(scan_lodo, "_sets", lambda parser, args: pytest.fail("read data before checking --shrinks"))
    with pytest.raises(SystemExit) as stop:
        scan_lodo.COMMANDS["lodo"](["--estimator", "SparseResidualInpainter", "--shrinks", value])
    err = capsys.readouterr().err
    assert stop.value.code == 2 and "argument --shrinks" in err
    if value == "2":  # a number, refused by SparseResidualInpainter's own constraint
        assert "shrink must be a number in (0, 1]" in err
