"""scan_lodo.py density --regions: where in its column each unmeasured pixel lies."""

from __future__ import annotations

import numpy as np
import pytest


@pytest.fixture(scope="module")
def scan_lodo(load_experiment):
    return load_experiment("scan_lodo")


def test_regions_split_each_column_at_its_top_and_lowest_measurement(scan_lodo):
    x = np.full((100, 6), np.nan, np.float32)
    x[30::20, :3] = 10.0  # lines at rows 30, 50, 70, 90 in the left half
    x[60, 3:5] = 20.0  # one line at row 60 in two columns; the last column has none
    parts = scan_lodo.column_regions(x)
    unmeasured = np.isnan(x)
    # every unmeasured pixel in exactly one region, no measured pixel in any
    stacked = np.stack(list(parts.values()))
    assert (stacked.sum(0) == unmeasured).all()
    assert parts["above"][:30, 0].all() and not parts["above"][30:, 0].any()
    assert parts["below"][91:, 0].all() and not parts["below"][:91, 0].any()
    assert parts["between <=8 px"][31:39, 0].all() and parts["between >8 px"][39:42, 0].all()
    assert parts["above"][:60, 3].all() and parts["below"][61:, 3].all()
    assert parts["above"][:, 5].all()  # a column without a measurement lies above it throughout


def test_residual_probe_learns_a_correction_of_harmonic_and_keeps_the_scan(scan_lodo):
    from inpaintenv.data import SyntheticStreets
    from inpaintenv.data.inputs import method_input
    from inpaintenv.methods.registry import make_method

    frames = SyntheticStreets(n=4, seed=2, frame_shape=(64, 160), frames_per_drive=2, input="scan-rings16-v1")
    probe = scan_lodo.ResidualProbe().fit([frames], pixels=500)
    harmonic, errs = make_method("harmonic"), {"probe": [], "harmonic": []}
    for i in range(len(frames)):
        scan, gt = (a[0] for a in frames.load_pairs([i]))
        x = method_input(scan, np.zeros(scan.shape, bool), "scan")
        pred = probe.predict(x)
        measured = ~np.isnan(x)
        assert np.array_equal(pred[measured], x[measured]) and np.isfinite(pred).all() and (pred > 0).all()
        scored = np.isnan(x) & (gt > 0)
        errs["probe"].append(np.sqrt(np.mean((pred[scored] - gt[scored]) ** 2)))
        errs["harmonic"].append(np.sqrt(np.mean((harmonic.predict(x)[scored] - gt[scored]) ** 2)))
    # fitted to truth minus harmonic on these frames: closer to their truth than harmonic
    assert np.mean(errs["probe"]) < np.mean(errs["harmonic"])


def test_holes_are_cut_into_the_scan_at_their_density_and_scored_inside_the_hole(scan_lodo, monkeypatch):
    from inpaintenv.masks import get_protocol

    class Frames:
        frame_ids = ["2011_09_26_drive_9001_sync/image_02/0000000005.png"]

        def __len__(self):
            return 1

        def load_pairs(self, index):
            scan = np.zeros((64, 160), np.float32)
            scan[::2] = 10.0  # a line every other row
            return scan[None], np.full((1, 64, 160), 12.0, np.float32)

    monkeypatch.setattr(scan_lodo, "crop_calibration", lambda root, day, camera: None)
    # Stand-in for ring thinning: every k-th line kept, for a k-th of the rings.
    monkeypatch.setattr(scan_lodo, "thinned", lambda scan, density, calibration, seed: np.where(
        (np.arange(scan.shape[0]) % (2 * (density[1] or 1)) == 0)[:, None], scan, 0.0))
    labels = ("rect-v1 hole", "16 beams + rect-v1 hole", "16 beams")
    units = list(scan_lodo.density_units("root", Frames(), (0, 1), labels))
    assert [u[0] for u in units] == ["16 beams", "rect-v1 hole", "rect-v1 hole", "16 beams + rect-v1 hole",
                                     "16 beams + rect-v1 hole"]
    for (label, x, gt, scored), seed in zip(units[1:], (0, 1, 0, 1)):
        hole = get_protocol("rect-v1").mask((64, 160), seed, 0)
        every = 2 if label == "rect-v1 hole" else 8
        lines = (np.arange(64) % every == 0)[:, None]
        assert np.array_equal(scored, hole) and np.isnan(x[hole]).all()
        assert np.array_equal(np.nan_to_num(x, nan=0.0) > 0, lines & ~hole)  # the density's lines, less the hole
