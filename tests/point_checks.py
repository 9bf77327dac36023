"""The check of a filled point cloud shared by the fill tests (imported by name)."""

from __future__ import annotations

import numpy as np

from inpaintenv.data import project_points


def check_points_added(out: np.ndarray, original: np.ndarray, filled: np.ndarray, mask: np.ndarray,
                       calib: object) -> None:
    """``out`` is ``original`` bit for bit, then one new point (intensity 0) per ``mask`` pixel that
    projects back onto it at the depth ``filled`` gives."""
    assert len(out) == len(original) + mask.sum()
    np.testing.assert_array_equal(out[: len(original)], original)  # every original point, bit for bit
    new = out[len(original):]
    assert (new[:, 3] == 0).all()
    u, v, z = project_points(new, calib)
    rows, cols = np.nonzero(mask)
    np.testing.assert_array_equal(np.rint(u), cols)
    np.testing.assert_array_equal(np.rint(v), rows)
    np.testing.assert_allclose(z, filled[mask], rtol=1e-5)
