"""Method-specific tests of the classical inpainters (the contract is in test_common)."""

from __future__ import annotations

from fractions import Fraction

import cv2
import numpy as np
import pytest
from scipy import ndimage

from estimators.classical import (
    ConstantInpainter,
    HarmonicInpainter,
    IPBasicInpainter,
    IterativeBilateralInpainter,
    NavierStokesInpainter,
    NearestInpainter,
    ScanlineInpainter,
    TeleaInpainter,
)
from estimators.classical.harmonic import harmonic_fill
from estimators.classical.nearest import nearest_fill
from estimators.classical.scanline import scanline_fill


def _holed(depth: np.ndarray, top: int, left: int, h: int, w: int) -> np.ndarray:
    x = depth.astype(np.float32).copy()
    x[top : top + h, left : left + w] = np.nan
    return x


@pytest.mark.parametrize(
    "estimator, param, bad",
    [
        (TeleaInpainter(), "radius", 0),
        (TeleaInpainter(), "radius", 2.5),
        (TeleaInpainter(), "fill", "holes"),
        (NavierStokesInpainter(), "fill", None),
        (IterativeBilateralInpainter(), "iterations", 0),
        (IterativeBilateralInpainter(), "d", 40),
        (IterativeBilateralInpainter(), "sigma_color", -1.0),
        (IterativeBilateralInpainter(), "sigma_space", float("nan")),
        (IterativeBilateralInpainter(), "sigma_color", Fraction(1, 2)),  # not a float: named, not numpy's TypeError
        (IPBasicInpainter(), "max_depth", 0.05),
        (IPBasicInpainter(), "large_hole_kernel", 30),
        (IPBasicInpainter(), "blur", "median"),
        (IPBasicInpainter(), "fallback", "zero"),
        (IPBasicInpainter(), "extrapolate", "yes"),
        (HarmonicInpainter(), "iterations", True),
        (HarmonicInpainter(), "inverse", "yes"),
        (ScanlineInpainter(), "inverse", 1),
        (ScanlineInpainter(), "vertical", "no"),
        (NearestInpainter(), "n_jobs", 0),
        (ConstantInpainter(), "n_jobs", 1.5),
        (ConstantInpainter(), "keep_observed", None),
    ],
)
def test_invalid_parameter_raises_naming_it(estimator, param, bad):
    est = estimator.set_params(**{param: bad})  # __init__/set_params never validate
    x = _holed(np.full((8, 8), 5.0), 2, 2, 3, 3)
    with pytest.raises((ValueError, TypeError), match=param):
        est.predict(x)
    with pytest.raises((ValueError, TypeError), match=param):
        est.fit(np.full((1, 8, 8), 5.0, np.float32))


@pytest.mark.parametrize("estimator", [
    TeleaInpainter(radius=np.int64(3), fill=np.str_("hole"), n_jobs=np.int32(-1)),
    IterativeBilateralInpainter(d=np.int64(31), sigma_color=np.float32(1.5), sigma_space=4, iterations=1),
    IPBasicInpainter(max_depth=np.float64(80.0), large_hole_kernel=np.int64(15), blur=np.str_("none"),
                     keep_observed=np.bool_(False)),
    HarmonicInpainter(iterations=np.int64(2), inverse=np.bool_(True)),
])
def test_numpy_scalars_are_accepted_as_their_python_kind(estimator):
    x = _holed(np.full((8, 8), 5.0), 2, 2, 3, 3)
    assert np.isfinite(estimator.predict(x)).all()


@pytest.mark.parametrize("cls", [TeleaInpainter, NavierStokesInpainter, IterativeBilateralInpainter])
def test_fill_hole_treats_unmeasured_as_zero(cls):
    depth = np.full((24, 48), 10.0, np.float32)
    depth[:, ::2] = 0.0  # semi-dense: every other column unmeasured
    x = _holed(depth, 6, 12, 10, 20)
    hole_mode = cls(fill="hole").predict(x)
    invalid_mode = cls(fill="invalid").predict(x)
    unmeasured_outside = (depth == 0) & ~np.isnan(x)
    # "hole" keeps the zeros outside the hole as depth 0 and drags the hole towards 0 ...
    assert (hole_mode[unmeasured_outside] == 0).all()
    assert hole_mode[np.isnan(x)].mean() < 9.0
    # ... "invalid" fills every unmeasured pixel from the 10 m measurements (Telea's
    # gradient term is not exact on a constant field, hence the tolerance).
    assert abs(invalid_mode[np.isnan(x)].mean() - 10.0) < 0.5
    assert (invalid_mode[unmeasured_outside] > 5).all()


@pytest.mark.parametrize("cls", [TeleaInpainter, NavierStokesInpainter])
@pytest.mark.parametrize("shape", [(1, 20), (20, 1), (2, 9)])
def test_opencv_fill_of_one_pixel_wide_frames_is_finite_and_near_the_measurements(cls, shape):
    """cv2.inpaint reads uninitialised memory on 1-pixel-wide images; the estimator pads.

    Other OpenCV calls in between leave garbage on the heap, which is what used to leak
    into the fill (NaN or values far outside the input, on about half of the runs).
    """
    rng = np.random.default_rng(0)
    for _ in range(30):
        junk = (rng.random((40, 50)) * 1e30).astype(np.float32)  # garbage left on the heap
        cv2.inpaint(junk, (rng.random(junk.shape) < 0.5).astype(np.uint8), 5.0, cv2.INPAINT_TELEA)
        x = (5 + 35 * rng.random(shape)).astype(np.float32)
        x[rng.random(shape) < 0.5] = np.nan
        x.flat[0], x.flat[-1] = 7.0, np.nan  # at least one measurement and one hole
        out = cls().predict(x)
        known = x[~np.isnan(x)]
        assert np.isfinite(out).all()
        # Telea's gradient term may overshoot the measured range a little; garbage is ~1e30.
        assert 0.5 * known.min() <= out.min() and out.max() <= 2 * known.max()


def test_nearest_fill_matches_exact_distance_transform():
    rng = np.random.default_rng(0)
    values = rng.uniform(1, 50, (40, 60)).astype(np.float32)
    known = np.zeros((40, 60), bool)
    known[::9, ::13] = True  # well separated, so no ties
    ours = nearest_fill(values, known)
    _, (r, c) = ndimage.distance_transform_edt(~known, return_indices=True)
    agree = (ours == values[r, c]).mean()
    assert agree > 0.97  # OpenCV's 5×5 mask approximates the Euclidean distance
    np.testing.assert_array_equal(ours[known], values[known])


def test_scanline_is_exact_on_rows_linear_in_depth():
    depth = np.tile(np.linspace(5, 40, 64, dtype=np.float32), (16, 1))
    x = _holed(depth, 3, 10, 8, 40)
    np.testing.assert_allclose(ScanlineInpainter().predict(x), depth, rtol=1e-5)


def test_scanline_inverse_is_exact_on_rows_linear_in_inverse_depth():
    depth = np.tile(1.0 / np.linspace(0.02, 0.5, 64), (16, 1)).astype(np.float32)
    x = _holed(depth, 3, 10, 8, 40)
    np.testing.assert_allclose(ScanlineInpainter(inverse=True).predict(x), depth, rtol=1e-4)
    assert np.abs(ScanlineInpainter().predict(x) - depth).max() > 1.0


def test_scanline_fills_rows_without_measurements_vertically():
    values = np.array([[2.0, 2, 2], [0, 0, 0], [0, 0, 0], [8, 8, 8]])
    out = scanline_fill(values, values > 0)
    np.testing.assert_allclose(out[:, 0], [2, 4, 6, 8])


def test_scanline_vertical_bridges_short_wide_holes():
    # Depth changes non-linearly along the row but not down the column, so a short,
    # wide hole is bridged far better vertically (gap 4) than along rows (gap 41).
    depth = np.tile((10 + 5 * np.sin(np.linspace(0, 6, 64))).astype(np.float32), (24, 1))
    x = _holed(depth, 10, 12, 3, 40)
    rows_only = np.abs(ScanlineInpainter().predict(x) - depth).max()
    both = np.abs(ScanlineInpainter(vertical=True).predict(x) - depth).max()
    assert both < rows_only / 3


def test_harmonic_reproduces_a_plane():
    yy, xx = np.mgrid[0:64, 0:96].astype(np.float32)
    plane = 10 + 0.1 * yy + 0.05 * xx  # harmonic: the exact Laplace solution
    known = np.ones_like(plane, bool)
    known[10:50, 20:80] = False
    out = harmonic_fill(plane, known, iterations=50)
    np.testing.assert_allclose(out, plane, atol=0.05)


def test_harmonic_inverse_reproduces_a_road_seen_in_perspective():
    # A flat road 1.65 m below a camera with focal 720 px: depth = 1.65 * 720 / (v - v0),
    # so inverse depth is affine in the row (and any plane's is affine in u and v).
    yy, xx = np.mgrid[0:64, 0:96].astype(np.float32)
    road = 1.65 * 720 / (yy + 20 + 0.02 * xx)
    x = _holed(road, 10, 20, 40, 60)
    inverse = HarmonicInpainter(inverse=True).predict(x)
    depth = HarmonicInpainter().predict(x)
    hole = np.isnan(x)
    # Exact up to the solver's convergence (50 Jacobi sweeps per level: < 1 %) ...
    np.testing.assert_allclose(inverse[hole], road[hole], rtol=0.01)
    # ... while interpolating depth bends the plane (18 % off here).
    assert np.abs(depth[hole] - road[hole]).max() > 10 * np.abs(inverse[hole] - road[hole]).max()


def test_ipbasic_fills_holes_wider_than_its_kernels():
    depth = np.full((96, 256), 12.0, np.float32)
    depth[::3] = 0.0
    x = _holed(depth, 10, 20, 80, 200)  # far wider than the 31×31 kernel
    out = IPBasicInpainter().predict(x)
    np.testing.assert_allclose(out, 12.0, atol=1e-3)


def _published_fast_fill(depth: np.ndarray, max_depth: float = 100.0) -> np.ndarray:
    """IP-Basic's published fast fill without extrapolation, Gaussian blur, from its description."""
    import cv2

    d = depth.copy()
    valid = d > 0.1
    d[valid] = max_depth - d[valid]
    d = cv2.dilate(d, np.array([[0, 0, 1, 0, 0], [0, 1, 1, 1, 0], [1] * 5, [0, 1, 1, 1, 0], [0, 0, 1, 0, 0]], np.uint8))
    d = cv2.morphologyEx(d, cv2.MORPH_CLOSE, np.ones((5, 5), np.uint8))
    empty = d < 0.1
    d[empty] = cv2.dilate(d, np.ones((7, 7), np.uint8))[empty]
    # No large-hole fill without extrapolation.
    d = cv2.medianBlur(d, 5)
    valid = d > 0.1
    d[valid] = cv2.GaussianBlur(d, (5, 5), 0)[valid]
    valid = d > 0.1
    d[valid] = max_depth - d[valid]
    return d


def test_ipbasic_large_hole_kernel_none_follows_the_published_code():
    rng = np.random.default_rng(3)
    depth = (np.linspace(40.0, 5.0, 64, dtype=np.float32)[:, None] + rng.uniform(0, 2, (64, 96))).astype(np.float32)
    depth[rng.random(depth.shape) < 0.5] = 0.0
    # A small hole: the 7x7 fill closes it, so the published code fills every pixel.
    small = _holed(depth, 30, 40, 6, 6)
    want = _published_fast_fill(np.nan_to_num(small, nan=0.0))
    assert (want > 0).all()
    got = IPBasicInpainter(large_hole_kernel=None, keep_observed=False).predict(small)
    np.testing.assert_array_equal(got, want)
    # A hole wider than the 7x7 fill: the published code runs its 31x31 fill only when
    # extrapolating; None does the same and leaves the rest to the fallback.
    wide = _holed(depth, 10, 20, 40, 50)
    published = IPBasicInpainter(large_hole_kernel=None, fallback="nearest").predict(wide)
    np.testing.assert_array_equal(published, IPBasicInpainter(large_hole_kernel=1, fallback="nearest").predict(wide))
    assert not np.array_equal(published, IPBasicInpainter(fallback="nearest").predict(wide))
    np.testing.assert_array_equal(
        IPBasicInpainter(large_hole_kernel=None, extrapolate=True).predict(wide),
        IPBasicInpainter(large_hole_kernel=31, extrapolate=True).predict(wide),
    )


def test_ipbasic_prefers_the_nearer_surface_at_a_depth_edge():
    depth = np.full((40, 40), 30.0, np.float32)
    depth[:, 20:] = 5.0
    sparse = depth.copy()
    sparse[:, 20:22] = 0.0  # unmeasured strip along the near side of the edge
    x = _holed(sparse, 0, 0, 1, 1)
    out = IPBasicInpainter(blur="none").predict(x)
    # Dilation of inverted depth grows the near (5 m) surface into the gap, although
    # column 20 touches the far (30 m) surface.
    assert (out[5:35, 20:22] < 10).all()


def test_ipbasic_refuses_depth_beyond_max_depth_instead_of_clipping():
    depth = np.tile(np.linspace(2.0, 60.0, 40, dtype=np.float32), (40, 1))
    x = _holed(depth, 10, 10, 20, 20)
    with pytest.raises(ValueError, match=r"X has depth up to 60 m, above max_depth=10 .*below 9.9 m\); raise max_depth"):
        IPBasicInpainter(max_depth=10).predict(x)
    with pytest.raises(ValueError, match=r"up to 180 m, above max_depth=100"):
        IPBasicInpainter().predict(x * 3)
    # Within range the fill is not capped: the far side of the hole is filled far.
    assert IPBasicInpainter(max_depth=61).predict(x)[np.isnan(x)].max() > 40


def test_constant_uses_the_frame_median():
    x = np.array([[1.0, 2.0, 0.0, 4.0], [3.0, np.nan, 100.0, 0.0]], np.float32)
    out = ConstantInpainter().predict(x)
    assert out[1, 1] == out[0, 2] == 3.0


def test_iterative_bilateral_keeps_known_depth_fixed():
    rng = np.random.default_rng(0)
    depth = rng.uniform(5, 20, (24, 48)).astype(np.float32)
    x = _holed(depth, 5, 5, 10, 10)
    out = IterativeBilateralInpainter(keep_observed=False, iterations=5).predict(x)
    known = ~np.isnan(x)
    np.testing.assert_array_equal(out[known], depth[known])


def test_n_jobs_restores_opencv_threads():
    before = cv2.getNumThreads()
    x = np.stack([_holed(np.full((16, 16), 3.0), 2, 2, 4, 4)] * 3)
    TeleaInpainter(n_jobs=2).predict(x)
    assert cv2.getNumThreads() == before


def test_n_jobs_all_cores_matches_serial():
    rng = np.random.default_rng(3)
    x = rng.uniform(2, 30, (5, 24, 40)).astype(np.float32)
    x[:, 4:12, 6:20] = np.nan
    x[rng.random(x.shape) < 0.5] = 0.0
    for est in (TeleaInpainter(), IPBasicInpainter(), HarmonicInpainter()):
        serial = est.set_params(n_jobs=None).predict(x)
        np.testing.assert_array_equal(est.set_params(n_jobs=-1).predict(x), serial)


@pytest.mark.parametrize("cls", ["TeleaInpainter", "NavierStokesInpainter"])
def test_opencv_fill_gives_every_pixel_a_valid_depth_far_from_sparse_measurements(cls):
    """cv2.inpaint oscillates into 0 and negative depth across a large region with two
    measurements (it did on a KITTI frame); every pixel to fill gets at least MIN_DEPTH."""
    import estimators.classical as classical
    from inpaintenv.conventions import MIN_DEPTH

    x = np.full((40, 36), np.nan, np.float32)
    x[20, 20], x[35, 33] = 2.6, 2.5
    out = getattr(classical, cls)().predict(x)
    assert np.isfinite(out).all() and out.min() >= MIN_DEPTH
    assert out[20, 20] == np.float32(2.6) and out[35, 33] == np.float32(2.5)
