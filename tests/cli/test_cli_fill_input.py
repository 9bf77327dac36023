"""``fill`` with a method routed by input kind: the output line says what filled what; ``--input`` forces the kind."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from estimators.classical import HarmonicInpainter, ScanlineInpainter
from estimators.learned import InputRoutedInpainter
from inpaintenv.methods.learned import DEFAULT_RELEASE, SCAN_DEFAULT
from inpaintenv.cli import main
from inpaintenv.data import SyntheticStreets, write_depth_png
from inpaintenv.exceptions import InvalidInputError
from inpaintenv.filling import fill
from inpaintenv.filling.methods import router

SHAPE = (64, 160)


def write_inputs(folder: Path, kind: str, n: int, seed: int = 1) -> list[Path]:
    """``n`` synthetic single scans (``kind="scan"``) or ground-truth maps (``"map"``) as KITTI PNGs."""
    ds = SyntheticStreets(n=n, frame_shape=SHAPE, input=kind, seed=seed)
    paths = [folder / f"{i}.png" for i in range(n)]
    for i, path in enumerate(paths):
        write_depth_png(path, ds.input_frame(i))
    return paths


def routed() -> InputRoutedInpainter:
    """A router of classical fills (no weights to load), named as the default's routes would be."""
    return InputRoutedInpainter(map_method=ScanlineInpainter(), scan_method=HarmonicInpainter(),
                                scan_name="harmonic", map_name="scanline")


def test_pretrained_states_which_method_filled_scans_and_maps(tmp_path, capsys):
    write_inputs(tmp_path / "in" / "scans", "scan", 3)
    write_inputs(tmp_path / "in" / "maps", "map", 2)
    assert main(["fill", str(tmp_path / "in"), "--missing", "--out", str(tmp_path / "out"), "-q"]) == 0
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert last.startswith("fill: 5 written, 0 skipped, 0 failed; pretrained filled "), last
    assert f"3 as scans with {SCAN_DEFAULT}" in last and f"2 as maps with {DEFAULT_RELEASE}" in last


def test_input_forces_the_kind_and_is_part_of_what_made_an_output(tmp_path, capsys):
    write_inputs(tmp_path / "maps", "map", 2)
    out = str(tmp_path / "out")
    assert main(["fill", str(tmp_path / "maps"), "--missing", "--input", "scan", "--out", out, "-q"]) == 0
    assert capsys.readouterr().err.strip().endswith(f"; pretrained filled 2 as scans with {SCAN_DEFAULT}")
    assert main(["fill", str(tmp_path / "maps"), "--missing", "--input", "map", "--out", out, "-q"]) == 1
    assert 'made with input "scan" (now "map")' in capsys.readouterr().err


def test_input_is_refused_in_one_line_by_a_method_that_fills_every_kind_alike(tmp_path, capsys):
    write_inputs(tmp_path / "in", "scan", 1)
    rc = main(["fill", str(tmp_path / "in"), "--missing", "--input", "scan", "-m", "harmonic",
               "--out", str(tmp_path / "out"), "-q"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 1 and len(err) == 1 and "--input applies to" in err[0] and "harmonic" in err[0]
    assert not (tmp_path / "out" / "0.png").exists()
    with pytest.raises(InvalidInputError, match="input"):
        fill([tmp_path / "in"], tmp_path / "out", method="harmonic", missing=True, input="lidar", progress=False)


def test_routes_are_counted_per_written_input_in_python(tmp_path):
    write_inputs(tmp_path / "in" / "a_scans", "scan", 3)
    write_inputs(tmp_path / "in" / "b_maps", "map", 2)
    dense = tmp_path / "in" / "c_dense" / "z.png"  # nothing to fill: written, but filled by no route
    write_depth_png(dense, np.full(SHAPE, 7.0, np.float32))
    report = fill([tmp_path / "in"], tmp_path / "out", method=routed(), missing=True, progress=False, batch_size=2)
    assert report.ok and len(report.written) == 6
    assert report.routes == {("scan", "harmonic"): 3, ("map", "scanline"): 2}
    assert report.summary().endswith("filled 3 as scans with harmonic, 2 as maps with scanline")
    forced = fill([tmp_path / "in" / "b_maps"], tmp_path / "out2", method=routed(), missing=True, input="scan",
                  progress=False)
    assert forced.routes == {("scan", "harmonic"): 2}


def test_an_interval_wrapper_is_looked_through_and_other_methods_state_nothing(tmp_path):
    est = routed()
    assert router(est) is est and router(SimpleNamespace(estimator=est, predict=est.predict)) is est
    assert router(HarmonicInpainter()) is None
    write_inputs(tmp_path / "in", "scan", 1)
    report = fill([tmp_path / "in"], tmp_path / "out", method="harmonic", missing=True, progress=False)
    assert report.routes == {} and report.summary() == "fill: 1 written, 0 skipped, 0 failed"


def test_pretrained_says_it_filled_a_sparser_sensors_scan_as_a_sparse_scan(tmp_path, capsys):
    from inpaintenv.methods.learned import SPARSE_DEFAULT

    write_inputs(tmp_path / "in" / "full", "scan", 1)
    for i in range(2):  # a LiDAR of few lines: a sloped ground on every 20th row, every 3rd column
        lines = np.zeros(SHAPE, np.float32)
        lines[i::20, ::3] = np.linspace(40.0, 5.0, SHAPE[0], dtype=np.float32)[i::20, None]
        write_depth_png(tmp_path / "in" / "thin" / f"{i}.png", lines)
    assert main(["fill", str(tmp_path / "in"), "--missing", "--out", str(tmp_path / "out"), "-q"]) == 0
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert f"1 as scans with {SCAN_DEFAULT}" in last and f"2 as sparse scans with {SPARSE_DEFAULT}" in last, last


def test_input_is_checked_once_per_fill(tmp_path, monkeypatch):
    import inpaintenv.filling.methods
    import inpaintenv.filling.options

    calls: list = []
    original = inpaintenv.filling.methods.check_input_choice

    def counting(value):
        calls.append(value)
        return original(value)

    for module in (inpaintenv.filling.methods, inpaintenv.filling.options):
        monkeypatch.setattr(module, "check_input_choice", counting)
    write_inputs(tmp_path / "in", "map", 2)
    fill([tmp_path / "in"], tmp_path / "out", method=routed(), missing=True, input="scan", progress=False,
         batch_size=1)
    assert calls == ["scan"]  # at fill's entry, not again where the method is made or per input


def test_pretrained_says_it_filled_scattered_points_as_a_scattered_point_scan(tmp_path, capsys):
    from inpaintenv.methods.learned import POINTS_DEFAULT

    write_inputs(tmp_path / "in" / "full", "scan", 1)
    points = np.zeros(SHAPE, np.float32)  # points 30 px apart along every 3rd row, as a tenth of a scan's
    for row in range(0, SHAPE[0], 3):
        points[row, (row * 7) % 30::30] = 40.0 - 35.0 * row / SHAPE[0]
    write_depth_png(tmp_path / "in" / "points.png", points)
    assert main(["fill", str(tmp_path / "in"), "--missing", "--out", str(tmp_path / "out"), "-q"]) == 0
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert f"1 as scans with {SCAN_DEFAULT}" in last and f"1 as scattered-point scans with {POINTS_DEFAULT}" in last, last
