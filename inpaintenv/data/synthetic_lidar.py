"""The sensors of SyntheticStreets: a pinhole camera with KITTI's intrinsics and a 64-beam LiDAR.

``single_scan`` simulates one scan of a dense render (KITTI's ``velodyne_raw``) and
``accumulated_scans`` eleven scans accumulated around a frame (KITTI's semi-dense ground
truth). Sampled pixels keep the dense value exactly (no range noise).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .calibration import Calibration

__all__ = ["Camera", "accumulated_scans", "lidar_calibration", "single_scan", "KITTI_FX", "KITTI_FY", "KITTI_CX", "KITTI_CY", "KITTI_RAW_SHAPE"]

# KITTI P_rect_02 of 2011_09_26 (the raw 1242x375 image).
KITTI_FX = KITTI_FY = 721.5377
KITTI_CX, KITTI_CY = 609.5593, 172.854
KITTI_RAW_SHAPE = (375, 1242)

# Velodyne HDL-64E: 32 upper lasers +2 .. -8.33 deg, 32 lower lasers -8.83 .. -24.8 deg.
BEAM_ELEVATIONS_DEG = np.concatenate([np.linspace(2.0, -8.33, 32), np.linspace(-8.83, -24.8, 32)])
LIDAR_OFFSET = (0.0, -0.08, -0.27)  # lidar in camera coordinates (x right, y down, z forward)
# In the real slice's velodyne_raw the top returns sit at +2.9..+4.5 deg seen from the
# camera (vehicle pitch, mounting), not +2 deg: tilt the simulated lidar up by 2 deg.
# Applied as an elevation offset (exact straight ahead, ~0.5 deg less at the image edge).
LIDAR_PITCH_DEG = 2.0
AZIMUTH_STEP_DEG = 0.17  # horizontal spacing of one laser's returns at 10 Hz
RETURN_PROB = 0.8  # fraction of lidar returns kept (dark/specular surfaces drop out)
GT_SCAN_OFFSETS = range(-5, 6)  # KITTI accumulates 11 scans around each frame
GT_KEEP_PROB = 0.62  # accumulated points surviving KITTI's consistency filtering


@dataclass(frozen=True)
class Camera:
    """Pinhole camera with KITTI's intrinsics, principal point shifted by a bottom-centre crop."""

    shape: tuple[int, int]

    @property
    def cx(self) -> float:
        return KITTI_CX - (KITTI_RAW_SHAPE[1] - self.shape[1]) // 2

    @property
    def cy(self) -> float:
        return KITTI_CY - (KITTI_RAW_SHAPE[0] - self.shape[0])

    def rays(self) -> tuple[np.ndarray, np.ndarray]:
        """Per-column ``x/z`` and per-row ``y/z`` of the pixel rays (camera frame)."""
        h, w = self.shape
        a = (np.arange(w) - self.cx) / KITTI_FX
        b = (np.arange(h) - self.cy) / KITTI_FY
        return a, b


def lidar_calibration(camera: Camera) -> Calibration:
    """The projection of the simulated LiDAR's frame (x forward, y left, z up, origin at the lasers) into ``camera``.

    Each simulated laser sweeps a cone of constant elevation in this frame, so
    :func:`~inpaintenv.data.thinning.ring_map` finds its rings (with laser height 0).
    """
    h, w = camera.shape
    k = np.array([[KITTI_FX, 0.0, camera.cx], [0.0, KITTI_FY, camera.cy], [0.0, 0.0, 1.0]])
    to_camera = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])  # forward, left, up -> right, down, forward
    return Calibration(k @ np.hstack([to_camera, np.asarray(LIDAR_OFFSET)[:, None]]), (w, h), "synthetic")


_LUT_STEP = 1e-4  # resolution of the nearest-beam table in tan(elevation)


@lru_cache(maxsize=1)
def _beam_lut() -> tuple[float, np.ndarray, np.ndarray]:
    """Nearest beam (index and tan(elevation)) for tan(elevation) quantised by ``_LUT_STEP``."""
    tan_beams = np.tan(np.deg2rad(BEAM_ELEVATIONS_DEG + LIDAR_PITCH_DEG))
    lo = tan_beams.min() - 0.01
    grid = lo + _LUT_STEP * np.arange(int((tan_beams.max() + 0.01 - lo) / _LUT_STEP) + 2)
    nearest = np.abs(grid[:, None] - tan_beams[None, :]).argmin(axis=1)
    return lo, nearest.astype(np.intp), tan_beams[nearest].astype(np.float32)


class _Points:
    """Camera-frame points of the pixels a lidar can reach, with what every scan needs.

    Only valid pixels not above the top laser as seen from the lidar ``min_forward``
    metres ahead are kept: a point above the lidar looks lowest from the pose farthest
    from it (the least forward one), so that pose bounds all scans. This drops the high
    facade and tree pixels no laser reaches before the per-scan work.
    """

    def __init__(self, depth: np.ndarray, camera: Camera, min_forward: float = 0.0):
        a, b = (r.astype(np.float32) for r in camera.rays())
        # Whole-image arithmetic, then one gather per array (cheaper than compressing twice).
        x2 = depth * a[None, :]
        x2 *= x2
        up = np.float32(LIDAR_OFFSET[1]) - depth * b[:, None]  # height above the lidar
        dz = depth - np.float32(LIDAR_OFFSET[2] + min_forward)
        rh = np.sqrt(x2 + dz * dz)
        tan_top = np.float32(np.tan(np.deg2rad(BEAM_ELEVATIONS_DEG.max() + LIDAR_PITCH_DEG)) + 0.01)
        self.flat = np.flatnonzero((depth > 0) & (up < tan_top * rh))
        self.t = self.z = depth.take(self.flat)
        self.x2 = x2.take(self.flat)
        self.up = up.take(self.flat)
        self.half_px = np.float32(0.5 / KITTI_FY) * self.t  # half a pixel row, in metres at the point

    def scatter(self, keep: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
        """A depth map holding the kept points, 0 elsewhere."""
        out = np.zeros(shape, dtype=np.float32)
        idx = np.flatnonzero(keep)
        out.ravel()[self.flat[idx]] = self.t[idx]
        return out


def _beam_hits(
    p: _Points, forward: float, buf: tuple[np.ndarray, np.ndarray] | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Points that some laser's elevation passes within half a pixel of, seen from a
    lidar ``forward`` metres ahead of this frame's; and the index (into the nearest-beam
    table) of that laser. ``buf``: two float32 work arrays of the points' size, reused
    across scans (in-place arithmetic is ~20 % faster than temporaries here)."""
    lo, nearest, tan_near = _beam_lut()
    rh, work = buf if buf is not None else (np.empty_like(p.t), np.empty_like(p.t))
    # rh = horizontal distance from the lidar
    np.subtract(p.z, np.float32(LIDAR_OFFSET[2] + forward), out=rh)
    np.multiply(rh, rh, out=rh)
    np.add(rh, p.x2, out=rh)
    np.sqrt(rh, out=rh)
    # q = nearest-beam table index of tan(elevation) = up / rh
    np.divide(p.up, rh, out=work)
    np.subtract(work, np.float32(lo), out=work)
    np.multiply(work, np.float32(1.0 / _LUT_STEP), out=work)
    q = work.astype(np.intp)
    # |tan_e - tan_beam| < half_px / rh, multiplied through by rh. mode="clip" maps
    # elevations outside the table to the top/bottom laser (and skips bounds checks).
    tan_near.take(q, out=work, mode="clip")
    np.multiply(work, rh, out=work)
    np.subtract(p.up, work, out=work)
    np.abs(work, out=work)
    return work < p.half_px, q


def single_scan(depth: np.ndarray, camera: Camera, rng: np.random.Generator) -> np.ndarray:
    """One 64-beam scan: each laser returns at azimuths ``phase + k * step``; a pixel is
    sampled when a laser's elevation and one of its azimuths fall inside it."""
    p = _Points(depth, camera)
    hit, q = _beam_hits(p, 0.0)
    idx = np.flatnonzero(hit)  # the azimuth test only for the ~20 % passing elevation
    _, nearest, _ = _beam_lut()
    a, _ = camera.rays()
    az = np.arctan(a)
    width = np.cos(az) ** 2 / KITTI_FX  # angular width of each column
    step = np.deg2rad(AZIMUTH_STEP_DEG)
    phase = rng.uniform(0.0, step, size=len(BEAM_ELEVATIONS_DEG))
    az_hit = np.mod(az[None, :] + width / 2 - phase[:, None], step) < width  # (beams, columns)
    beam = nearest.take(q.take(idx), mode="clip")
    cols = p.flat.take(idx) % depth.shape[1]
    kept = az_hit[beam, cols] & (rng.random(idx.shape, dtype=np.float32) < RETURN_PROB)
    out = np.zeros_like(depth)
    sel = idx[kept]
    out.ravel()[p.flat[sel]] = p.t[sel]
    return out


def accumulated_scans(
    depth: np.ndarray, moving: np.ndarray, camera: Camera, speed: float, rng: np.random.Generator
) -> np.ndarray:
    """KITTI-style semi-dense ground truth: scans at frames ``i-5 .. i+5`` accumulated.

    The elevation test is exact per scan; the azimuth test is drawn at the end: a pixel
    passed by ``c`` lasers is kept with probability ``1 - (1 - p)^c``, ``p`` being the
    chance that a laser returns inside one column. Moving objects keep only the
    current scan (KITTI drops their smeared points).
    """
    forwards = [k * speed for k in GT_SCAN_OFFSETS]
    p = _Points(depth, camera, min_forward=min(forwards))
    static = ~moving.ravel()[p.flat]
    count = np.zeros(p.t.shape, dtype=np.uint8)
    buf = (np.empty_like(p.t), np.empty_like(p.t))
    for f in forwards:
        hit, _ = _beam_hits(p, f, buf)
        count += hit if f == 0 else hit & static
    p_col = min(1.0, (1.0 / KITTI_FX) / np.deg2rad(AZIMUTH_STEP_DEG)) * RETURN_PROB
    keep_prob = (1.0 - (1.0 - p_col) ** np.arange(len(forwards) + 1)).astype(np.float32)
    kept = rng.random(count.shape, dtype=np.float32) < keep_prob[count] * np.float32(GT_KEEP_PROB)
    return p.scatter(kept, depth.shape)
