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
