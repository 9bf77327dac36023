"""scan_lodo.py holes: the gap statistics it reports, and its distance chosen with one recording day left out."""

from __future__ import annotations

import numpy as np
import pytest


@pytest.fixture(scope="module")
def scan_lodo(load_experiment):
    return load_experiment("scan_lodo")


def lines(shape=(120, 200), top=20, step=4):
    """A scan-like frame: a measured line every ``step`` rows from ``top`` down, NaN elsewhere."""
    x = np.full(shape, np.nan, np.float32)
    x[top::step] = 10.0
    return x


def test_a_rectangle_cut_into_the_scan_is_an_enclosed_gap_its_lines_are_not(scan_lodo):
    x = lines()
    assert scan_lodo.enclosed_gap(x) <= 2.5  # halfway between two lines
    holed = x.copy()
    holed[40:100, 50:150] = np.nan  # 60 x 100 px
    assert 31 <= scan_lodo.enclosed_gap(holed) <= 33  # half the 64 rows between the lines around it


def test_sky_above_a_partial_top_line_is_in_the_band_but_not_enclosed(scan_lodo):
    x = lines()
    x[20, 100:] = np.nan  # the top line reaches half the width
    x[21:60, :] = np.nan  # and nothing below it for 40 rows
    x[60::4] = 10.0
    gap = scan_lodo.gap_distance(x)
    assert gap[:20].max() == 0.0  # above the band: not counted
    assert gap.max() > 30  # the right half's empty rows, open above
    assert scan_lodo.enclosed_gap(x) <= 21  # the left half's, under the top line


def test_distance_chosen_on_the_two_other_days(scan_lodo, capsys):
    classical = {m: [10.0, 10.0] for m in scan_lodo.CLASSICAL}

    def row(best_d):  # the composition is best at best_d on this day
        out = {**classical, "pretrained": [9.0, 9.0]}
        out.update({f"blend {d}": [8.0 if d == best_d else 9.0] * 2 for d in scan_lodo.HOLE_DISTANCES})
        return {"rect-v1 hole": out}

    days = {"2011_09_26": row(48), "2011_09_30": row(48), "2011_10_03": row(8)}
    scan_lodo._holes_lodo(days, {})
    said = capsys.readouterr().out
    assert "left out 2011_10_03: D 48 (chosen on 2011_09_26, 2011_09_30) | composition 0.900" in said
    # the other two days disagree (48 vs 8): the first distance of the tie, 8
    assert "left out 2011_09_26: D 8 (chosen on 2011_09_30, 2011_10_03) | composition 0.900" in said
