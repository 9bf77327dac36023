"""IPBasicInpainter configured as IP-Basic's KITTI submission equals its published fast fill on a sparse scan.

The published code (github.com/kujason/ip_basic, ``fill_in_fast``) is not in the repository;
``_published_paper_fill`` follows its steps for the paper's setting (``extrapolate=True``,
``blur_type='gaussian'``). perf/published_ipbasic.py runs the real code on KITTI.
"""

from __future__ import annotations

import cv2
import numpy as np

from estimators.classical import IPBasicInpainter

DIAMOND_5 = np.array([[0, 0, 1, 0, 0], [0, 1, 1, 1, 0], [1] * 5, [0, 1, 1, 1, 0], [0, 0, 1, 0, 0]], np.uint8)


def _published_paper_fill(depth: np.ndarray, max_depth: float = 100.0) -> np.ndarray:
    """The published fast fill with extension to the top and the 31x31 fill, Gaussian blur."""
    d = depth.copy()
    valid = d > 0.1
    d[valid] = max_depth - d[valid]
    d = cv2.dilate(d, DIAMOND_5)
    d = cv2.morphologyEx(d, cv2.MORPH_CLOSE, np.ones((5, 5), np.uint8))
    empty = d < 0.1
    d[empty] = cv2.dilate(d, np.ones((7, 7), np.uint8))[empty]
    top = np.argmax(d > 0.1, axis=0)
    for col in range(d.shape[1]):
        d[: top[col], col] = d[top[col], col]
    empty = d < 0.1
    d[empty] = cv2.dilate(d, np.ones((31, 31), np.uint8))[empty]
    d = cv2.medianBlur(d, 5)
    valid = d > 0.1
    d[valid] = cv2.GaussianBlur(d, (5, 5), 0)[valid]
    valid = d > 0.1
    d[valid] = max_depth - d[valid]
    return d


def _sparse_scan(rng: np.random.Generator) -> np.ndarray:
    """A scan-like frame: every 4th row measured with dropouts, nothing in the top third (sky)."""
    h, w = 72, 120
    depth = np.linspace(70.0, 4.0, h, dtype=np.float32)[:, None] + rng.uniform(0.0, 3.0, (h, w)).astype(np.float32)
    scan = np.zeros((h, w), np.float32)
    rows = np.arange(h // 3, h, 4)
    scan[rows] = np.where(rng.random((rows.size, w)) < 0.7, depth[rows], 0.0)
    return scan


def test_paper_configuration_equals_the_published_fast_fill_on_a_scan():
    scan = _sparse_scan(np.random.default_rng(5))
    want = _published_paper_fill(scan)
    assert (want > 0).all()  # the published fill reaches every pixel of this frame
    paper = IPBasicInpainter(extrapolate=True, large_hole_kernel=None, keep_observed=False)
    got = paper.predict(np.where(scan > 0, scan, np.nan))
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-4)
    # The registered default differs: no extension to the top, and measured pixels kept.
    default = IPBasicInpainter().predict(np.where(scan > 0, scan, np.nan))
    assert np.array_equal(default[scan > 0], scan[scan > 0])
    assert np.abs(default - want).max() > 0.1
