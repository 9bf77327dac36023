"""residual_features: every channel equals its definition, recomputed here one pixel at a time.

The features are computed at the pixels asked for with shared pieces (one labelled distance
transform, one cumulative scan per direction); a model fitted on them must read the same
numbers whatever the implementation, so each channel is pinned against a plain recomputation
from what the channel is: the window's nearest/farthest measurement by brute force, gaps and
endpoints by walking the row or column, the box share by a padded mean, the fills through
the single-fill functions that define them.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import cv2
import numpy as np
import pytest

from estimators.candidates import (DENSITY_BOX, NO_MEASUREMENT_DISTANCE, WINDOW, candidate_fills, residual_channels,
                                   residual_features, row_band_quantile)
from estimators.classical.harmonic import harmonic_fill
from estimators.classical.nearest import nearest_fill
from inpaintenv.data import SyntheticStreets
from inpaintenv.data.inputs import method_input
from inpaintenv.exceptions import InvalidInputError

FILLS = ("row-median", "row-far", "window-near", "window-far", "nearest")


def _scans() -> list[np.ndarray]:
    """Synthetic sparse scans (16 and 8 beams), a frame with one measurement, one with a measured row."""
    out = []
    for kind in ("scan-rings16-v1", "scan-rings8-v1"):
        inputs, _ = SyntheticStreets(n=2, seed=3, frame_shape=(72, 160), input=kind).load_pairs(range(2))
        out += list(method_input(inputs, np.zeros(inputs.shape, bool), "scan"))
    one = np.full((70, 90), np.nan, np.float32)
    one[50, 17] = 12.5
    line = np.full((66, 80), np.nan, np.float32)
    line[40] = np.linspace(3.0, 40.0, 80)
    return out + [one, line]


SCANS = _scans()


def _window(values: np.ndarray, known: np.ndarray, far: bool) -> np.ndarray:
    """Nearest / farthest measurement in the WINDOW x WINDOW window (clipped at the border);
    an empty window: the nearest measurement (nearest_fill); a measured pixel: itself."""
    r = WINDOW // 2
    padded = np.pad(np.where(known, values, np.nan), r, constant_values=np.nan)
    windows = np.lib.stride_tricks.sliding_window_view(padded, (WINDOW, WINDOW)).reshape(*values.shape, -1)
    empty = np.isnan(windows).all(axis=-1)
    windows = np.where(empty[..., None], 0.0, windows)  # no all-NaN reduction
    extreme = np.nanmax(windows, axis=-1) if far else np.nanmin(windows, axis=-1)
    return np.where(known, values, np.where(empty, nearest_fill(values, known), extreme)).astype(np.float32)


def _lines(values: np.ndarray, known: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pixels to and depth of the first measurement left, right, up and down of each (row, col), the
    pixel itself included: ``(P, 4)`` gaps (capped; none: NO_MEASUREMENT_DISTANCE) and depths (none: 0)."""
    gaps, ends = np.full((len(rows), 4), NO_MEASUREMENT_DISTANCE, np.float64), np.zeros((len(rows), 4))
    for p, (i, j) in enumerate(zip(rows, cols)):
        for d, (line, here, value) in enumerate(((known[i], j, values[i]), (known[i], j, values[i]),
                                                 (known[:, j], i, values[:, j]), (known[:, j], i, values[:, j]))):
            measured = np.flatnonzero(line)
            found = measured[measured <= here] if d % 2 == 0 else measured[measured >= here]
            if found.size:
                k = found.max() if d % 2 == 0 else found.min()
                gaps[p, d], ends[p, d] = min(abs(here - k), NO_MEASUREMENT_DISTANCE), value[k]
    return gaps, ends


def _share(known: np.ndarray) -> np.ndarray:
    """Measured share of the DENSITY_BOX box (OpenCV's default border: reflected, edge not repeated)."""
    r = DENSITY_BOX // 2
    padded = np.pad(known.astype(np.float64), r, mode="reflect")
    windows = np.lib.stride_tricks.sliding_window_view(padded, (DENSITY_BOX, DENSITY_BOX))
    return windows.mean(axis=(-2, -1))


def expected(x: np.ndarray, fills: tuple[str, ...], rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """``(P, C)`` features of the pixels (rows, cols), channel by channel from the definitions."""
    known = x > 0
    values = np.where(known, x, 0.0).astype(np.float32)
    channels = {"harmonic": harmonic_fill(values, known), "nearest": nearest_fill(values, known),
                "row-median": row_band_quantile(values, known, 0.5), "row-far": row_band_quantile(values, known, 0.9),
                "window-near": _window(values, known, far=False), "window-far": _window(values, known, far=True)}
    for name in fills:
        if name not in channels:
            channels[name] = candidate_fills(x, (name,))[0]
    per_pixel = [[channels[name][i, j] for name in ("harmonic", *fills)] for i, j in zip(rows, cols)]
    gaps, ends = _lines(values, known, rows, cols)
    distance = cv2.distanceTransform((~known).astype(np.uint8), cv2.DIST_L2, 5)[rows, cols]
    return np.column_stack([np.asarray(per_pixel), gaps, ends, distance, _share(known)[rows, cols]])


@pytest.mark.parametrize("frame", range(len(SCANS)))
def test_every_channel_equals_its_definition(frame):
    x = SCANS[frame]
    todo = np.isnan(x)
    rows, cols = np.nonzero(todo)
    feats, harmonic = residual_features(x, FILLS, todo)
    want = expected(x, FILLS, rows, cols)
    assert feats.dtype == np.float32 and feats.shape == want.shape == (todo.sum(), 1 + len(FILLS) + 10)
    assert feats.flags.c_contiguous
    # Exact everywhere but the box share, whose mean sums in another order (1e-4: float32 rounding).
    np.testing.assert_array_equal(feats[:, :-1], want[:, :-1].astype(np.float32))
    np.testing.assert_allclose(feats[:, -1], want[:, -1], rtol=0, atol=1e-6)
    np.testing.assert_array_equal(harmonic, feats[:, 0])


def test_the_frames_hold_empty_windows_and_unbounded_gaps():
    """The cases the shared pieces must get right are present in the frames tested."""
    empty = [nearest_fill(np.where(x > 0, x, 0), x > 0) != _window(np.where(x > 0, x, 0), x > 0, far=True)
             for x in SCANS[:4]]
    assert all(e.any() for e in empty)
    x = SCANS[0]
    gaps = residual_features(x, FILLS, np.isnan(x))[0][:, 1 + len(FILLS):1 + len(FILLS) + 4]
    assert (gaps == NO_MEASUREMENT_DISTANCE).any() and (gaps < 3).any()


def test_pixels_given_as_rows_and_cols_measured_ones_included_in_their_order():
    x = SCANS[1]
    rng = np.random.default_rng(0)
    rows, cols = rng.integers(0, x.shape[0], 300), rng.integers(0, x.shape[1], 300)
    rows[:20], cols[:20] = np.nonzero(x > 0)[0][:20], np.nonzero(x > 0)[1][:20]  # measured pixels too
    fills = (*FILLS, "scanline", "vertical-inverse", "harmonic-inverse", "ipbasic-scan")
    feats, harmonic = residual_features(x, fills, (rows, cols))
    want = expected(x, fills, rows, cols)
    np.testing.assert_array_equal(feats[:, :-1], want[:, :-1].astype(np.float32))
    np.testing.assert_allclose(feats[:, -1], want[:, -1], rtol=0, atol=1e-6)
    np.testing.assert_array_equal(feats[:20, 1:1 + len(fills)], np.repeat(x[rows[:20], cols[:20], None], len(fills), 1))


def test_channels_pixel_last_are_the_features_transposed():
    x = SCANS[2]
    channels, harmonic = residual_channels(x, FILLS, np.isnan(x))
    feats, harmonic_too = residual_features(x, FILLS, np.isnan(x))
    np.testing.assert_array_equal(channels.T, feats)
    np.testing.assert_array_equal(harmonic, harmonic_too)


@pytest.mark.parametrize("where, match", [
    (np.zeros((3, 3), bool), "bool mask"),
    (np.zeros((70, 90), np.uint8), "bool mask"),
    ((np.array([0, 70]), np.array([1, 2])), "inside the"),
    ((np.array([0.5]), np.array([1])), "inside the"),
])
def test_bad_pixels_are_one_clear_error(where, match):
    with pytest.raises(InvalidInputError, match=match):
        residual_features(SCANS[-2], FILLS, where)


def test_the_same_numbers_with_or_without_the_worker_thread(monkeypatch):
    import estimators.candidates as candidates
    from estimators._residual_features import _Inline

    x = SCANS[0]
    monkeypatch.setattr(candidates, "overlap", lambda: ThreadPoolExecutor(max_workers=1))
    threaded = residual_features(x, FILLS, np.isnan(x))
    monkeypatch.setattr(candidates, "overlap", _Inline)
    inline = residual_features(x, FILLS, np.isnan(x))
    np.testing.assert_array_equal(threaded[0], inline[0])
    np.testing.assert_array_equal(threaded[1], inline[1])


def test_gaps_and_endpoints_of_a_frame_too_wide_for_16_bit_indices():
    """Lines longer than int16 with the sentinels are scanned in int32: same definition."""
    x = np.full((8, 30000), np.nan, np.float32)
    x[2, [5, 7000, 29990]] = [4.0, 9.0, 30.0]
    x[6, 15000] = 12.0
    rows, cols = np.array([2, 2, 2, 5, 7, 0]), np.array([3, 5000, 29999, 15000, 100, 29000])
    feats, _ = residual_features(x, ("nearest",), (rows, cols))
    gaps, ends = _lines(np.nan_to_num(x), x > 0, rows, cols)
    np.testing.assert_array_equal(feats[:, 2:6], gaps.astype(np.float32))
    np.testing.assert_array_equal(feats[:, 6:10], ends.astype(np.float32))
