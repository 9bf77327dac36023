"""SyntheticStreets: procedural outdoor driving depth at KITTI's geometry (no download).

Each frame is ray-cast per pixel through a pinhole camera with KITTI's intrinsics
(1.65 m above a flat road) against a street of axis-aligned boxes (kerbs/sidewalks,
building facades with alleys, parked and moving cars, poles, tree trunks) and
ellipsoids (tree crowns). Sky and anything beyond 80 m is "no data" (0).

Rays are separable: with the camera yawed about the vertical axis only, a ray's x and
z components depend on the image column and its y component on the row, so each
object is intersected with one interval per column and one per row, combined by
broadcasting inside the object's screen rectangle.

Three kinds of frame are produced from the same dense render:

* ``"dense"``: the dense truth.
* ``"velodyne_raw"``: one simulated 64-beam scan (HDL-64E: elevations +2 deg to
  -24.8 deg, lidar 0.08 m above and 0.27 m behind the camera, tilted up by 2 deg as
  measured on the real slice).
* ``"groundtruth"``: 11 simulated scans at the poses of frames i-5..i+5 accumulated,
  like KITTI's semi-dense ground truth; moving cars only keep the current scan.

Sampled pixels keep the dense value exactly (no range noise).
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from ..conventions import check_frame_shape, check_int, check_seed
from .base import DepthDataset
from .calibration import Calibration
from .inputs import check_input_kind, input_kind
from .synthetic_lidar import (  # noqa: F401  (KITTI_* and Camera are part of this module's API)
    KITTI_CX, KITTI_CY, KITTI_FX, KITTI_FY, KITTI_RAW_SHAPE, Camera, accumulated_scans, lidar_calibration, single_scan,
)
from ..exceptions import InvalidInputError

__all__ = ["MAX_SYNTHETIC_FRAMES", "SyntheticStreets", "KITTI_FX", "KITTI_FY", "KITTI_CX", "KITTI_CY", "KITTI_RAW_SHAPE"]

CAMERA_HEIGHT = 1.65
MAX_DEPTH = 80.0
_T_NEAR = 0.3  # no surface closer than this to the camera
_KINDS = ("groundtruth", "velodyne_raw", "dense")


# ----------------------------------------------------------------------------- scene
@dataclass
class Scene:
    """One drive's street: boxes ``(N, 6)`` as x0, x1, y0, y1, z0, z1 (metres, y down,
    road at y = CAMERA_HEIGHT), per-box z velocity (m/frame, 0 = static) and ellipsoids
    ``(M, 6)`` as cx, cy, cz, rx, ry, rz."""

    boxes: list[tuple[float, ...]] = field(default_factory=list)
    velocity: list[float] = field(default_factory=list)
    ellipsoids: list[tuple[float, ...]] = field(default_factory=list)
    speed: float = 1.0  # ego metres per frame
    yaw: float = 0.0  # radians, camera heading relative to the street

    def box(self, x0: float, x1: float, h0: float, h1: float, z0: float, z1: float, v: float = 0.0) -> None:
        """Add a box spanning heights ``h0..h1`` above the road."""
        self.boxes.append((x0, x1, CAMERA_HEIGHT - h1, CAMERA_HEIGHT - h0, z0, z1))
        self.velocity.append(v)


def _add_sidewalk(scene: Scene, x_kerb: float, side: int, width: float, height: float, z: tuple[float, float]) -> None:
    x0, x1 = sorted((x_kerb, x_kerb + side * width))
    scene.box(x0, x1, 0.0, height, *z)


def _add_facades(scene: Scene, rng: np.random.Generator, x_front: float, side: int, z: tuple[float, float]) -> None:
    """A row of buildings along one side, with occasional alleys between them."""
    zc = z[0]
    while zc < z[1]:
        length = rng.uniform(8.0, 35.0)
        x = x_front + side * rng.uniform(0.0, 0.8)  # facades are not perfectly aligned
        x0, x1 = sorted((x, x + side * 12.0))
        scene.box(x0, x1, 0.0, rng.uniform(4.0, 18.0), zc, zc + length)
        zc += length + (rng.uniform(2.0, 10.0) if rng.random() < 0.35 else 0.0)


def _add_car(scene: Scene, rng: np.random.Generator, x_center: float, z0: float, v: float = 0.0) -> float:
    """A car as a body box plus a cabin box; returns its length."""
    length, width = rng.uniform(3.8, 4.9), rng.uniform(1.65, 1.9)
    x0, x1 = x_center - width / 2, x_center + width / 2
    scene.box(x0, x1, 0.25, rng.uniform(0.85, 1.0), z0, z0 + length, v)
    cabin = (z0 + 0.3 * length, z0 + 0.8 * length)
    scene.box(x0 + 0.1, x1 - 0.1, 0.9, rng.uniform(1.4, 1.6), *cabin, v)
    return length


def _add_parked_cars(scene: Scene, rng: np.random.Generator, x_center: float, z: tuple[float, float]) -> None:
    zc = z[0] + rng.uniform(0, 5)
    while zc < z[1]:
        if rng.random() < 0.6:
            zc += _add_car(scene, rng, x_center + rng.uniform(-0.2, 0.2), zc)
        else:
            zc += rng.uniform(3.0, 8.0)
        zc += rng.uniform(0.5, 3.0)


def _add_pole(scene: Scene, x: float, z: float, height: float) -> None:
    scene.box(x - 0.1, x + 0.1, 0.0, height, z - 0.1, z + 0.1)


def _add_tree(scene: Scene, rng: np.random.Generator, x: float, z: float) -> None:
    trunk = rng.uniform(1.8, 3.0)
    scene.box(x - 0.15, x + 0.15, 0.0, trunk + 0.5, z - 0.15, z + 0.15)
    r, ry = rng.uniform(1.2, 2.5), rng.uniform(1.2, 2.5)
    scene.ellipsoids.append((x, CAMERA_HEIGHT - trunk - 0.7 * ry, z, r, ry, r))


def build_scene(seed: int, drive: int, length: float) -> Scene:
    """The street of one drive, deterministic from ``(seed, drive)``."""
    rng = np.random.default_rng([seed, drive, 0])
    scene = Scene(speed=rng.uniform(0.7, 1.3), yaw=np.deg2rad(rng.uniform(-1.5, 1.5)))
    z = (-25.0, length + MAX_DEPTH + 10.0)
    lane = 3.5
    # Ego drives in the right lane (x = 0); kerbs at x_right and x_left.
    park_r, park_l = rng.random() < 0.6, rng.random() < 0.6
    x_right = rng.uniform(1.6, 2.2) + 2.2 * park_r
    x_left = -(rng.uniform(1.6, 2.2) + lane * rng.integers(1, 3) + 2.2 * park_l)
    for side, x_kerb, park in ((1, x_right, park_r), (-1, x_left, park_l)):
        width = rng.uniform(1.5, 4.0)
        _add_sidewalk(scene, x_kerb, side, width, rng.uniform(0.1, 0.18), z)
        if park:
            _add_parked_cars(scene, rng, x_kerb - side * 1.1, z)
        if rng.random() < 0.85:
            _add_facades(scene, rng, x_kerb + side * (width + rng.uniform(0.0, 3.0)), side, z)
            if rng.random() < 0.5:  # a second row seen through the alleys
                _add_facades(scene, rng, x_kerb + side * (width + rng.uniform(18.0, 30.0)), side, z)
        zc = z[0] + rng.uniform(0, 20)
        while zc < z[1]:  # poles near the kerb
            _add_pole(scene, x_kerb + side * 0.5, zc, rng.uniform(4.0, 8.0))
            zc += rng.uniform(15.0, 40.0)
        if rng.random() < 0.6:  # a row of trees on the sidewalk
            zc = z[0] + rng.uniform(0, 10)
            while zc < z[1]:
                _add_tree(scene, rng, x_kerb + side * min(width - 0.5, rng.uniform(1.0, 2.0)), zc)
                zc += rng.uniform(6.0, 15.0)
    # Traffic: cars ahead in the ego lane and oncoming cars in the left lane.
    for _ in range(rng.poisson(2.0)):
        if rng.random() < 0.5:
            _add_car(scene, rng, rng.uniform(-0.3, 0.3), rng.uniform(8.0, 60.0), v=scene.speed + rng.uniform(-0.4, 0.4))
        else:
            _add_car(scene, rng, -lane + rng.uniform(-0.3, 0.3), rng.uniform(10.0, 90.0), v=-rng.uniform(0.8, 1.5))
    return scene


# ----------------------------------------------------------------------------- rendering
def _slab(origin: float, direction: np.ndarray, lo: float, hi: float) -> tuple[np.ndarray, np.ndarray]:
    """Entry/exit ray parameters of the slab ``lo <= origin + t * direction <= hi``."""
    inv = 1.0 / direction
    t1, t2 = np.float32(lo - origin) * inv, np.float32(hi - origin) * inv
    return np.minimum(t1, t2), np.maximum(t1, t2)


def _span(valid: np.ndarray) -> slice | None:
    idx = np.flatnonzero(valid)
    return slice(idx[0], idx[-1] + 1) if idx.size else None


def _render_box(
    zbuf: np.ndarray, box: np.ndarray, origin: np.ndarray, dx: np.ndarray, dy: np.ndarray, dz: np.ndarray
) -> None:
    """Z-buffer one box into ``zbuf`` (rows x columns) in place."""
    xn, xf = _slab(origin[0], dx, box[0], box[1])
    zn, zf = _slab(origin[2], dz, box[4], box[5])
    cn, cf = np.maximum(xn, zn), np.minimum(xf, zf)
    rn, rf = _slab(origin[1], dy, box[2], box[3])
    cols, rows = _span((cn < cf) & (cf > _T_NEAR)), _span((rn < rf) & (rf > _T_NEAR))
    if cols is None or rows is None:
        return
    tn = np.maximum(cn[cols][None, :], rn[rows][:, None])
    tf = np.minimum(cf[cols][None, :], rf[rows][:, None])
    hit = (tn < tf) & (tn > _T_NEAR)
    sub = zbuf[rows, cols]
    np.minimum(sub, tn, out=sub, where=hit)


def _render_ellipsoid(
    zbuf: np.ndarray, ell: np.ndarray, origin: np.ndarray, dx: np.ndarray, dy: np.ndarray, dz: np.ndarray
) -> None:
    """Z-buffer one ellipsoid: solve |(t d - c) / r|^2 = 1 inside its bounding rectangle."""
    c = ell[:3] - origin
    r = ell[3:]
    box = np.array([c[0] - r[0], c[0] + r[0], c[1] - r[1], c[1] + r[1], c[2] - r[2], c[2] + r[2]])
    xn, xf = _slab(0.0, dx, box[0], box[1])
    zn, zf = _slab(0.0, dz, box[4], box[5])
    rn, rf = _slab(0.0, dy, box[2], box[3])
    cols = _span((np.maximum(xn, zn) < np.minimum(xf, zf)) & (np.minimum(xf, zf) > _T_NEAR))
    rows = _span((rn < rf) & (rf > _T_NEAR))
    if cols is None or rows is None:
        return
    a = ((dx[cols] / r[0]) ** 2 + (dz[cols] / r[2]) ** 2)[None, :] + ((dy[rows] / r[1]) ** 2)[:, None]
    b = (dx[cols] * c[0] / r[0] ** 2 + dz[cols] * c[2] / r[2] ** 2)[None, :] + (dy[rows] * c[1] / r[1] ** 2)[:, None]
    cc = float(np.sum((c / r) ** 2)) - 1.0
    disc = b * b - a * cc
    t = (b - np.sqrt(np.maximum(disc, 0.0))) / a
    hit = (disc > 0) & (t > _T_NEAR)
    sub = zbuf[rows, cols]
    np.minimum(sub, t, out=sub, where=hit)


#: Most frames a SyntheticStreets may have: their ids and drive names are lists held in
#: memory (about 100 bytes a frame); 1,000,000 is twelve times the full KITTI release.
MAX_SYNTHETIC_FRAMES: int = 1_000_000


def render_dense(scene: Scene, frame: int, camera: Camera, yaw_jitter: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Dense depth (float32, 0 = sky / beyond 80 m) and the mask of moving objects."""
    a, b = camera.rays()
    yaw = scene.yaw + yaw_jitter
    # float32 halves the memory traffic of the per-pixel work; 1 mm at 80 m is plenty.
    dx = (np.cos(yaw) * a + np.sin(yaw)).astype(np.float32)
    dz = (-np.sin(yaw) * a + np.cos(yaw)).astype(np.float32)
    dy = b.astype(np.float32)
    for d in (dx, dy, dz):  # a ray parallel to a slab would give 0 * inf = NaN
        d[d == 0] = 1e-12
    origin = np.array([0.0, 0.0, frame * scene.speed])
    with np.errstate(divide="ignore"):
        road = np.where(dy > 0, np.float32(CAMERA_HEIGHT) / dy, np.float32(np.inf))
    static = np.repeat(road[:, None], camera.shape[1], axis=1)
    moving = np.full(camera.shape, np.inf, dtype=np.float32)
    boxes = np.asarray(scene.boxes, dtype=np.float64).reshape(-1, 6).copy()
    vel = np.asarray(scene.velocity, dtype=np.float64)
    boxes[:, 4:6] += (vel * frame)[:, None]
    # Cull what is behind the camera or beyond the maximum range.
    near_z = origin[2] - 2.0
    far_z = origin[2] + MAX_DEPTH + 5.0
    keep = (boxes[:, 5] > near_z) & (boxes[:, 4] < far_z)
    for box, v in zip(boxes[keep], vel[keep]):
        _render_box(moving if v else static, box, origin, dx, dy, dz)
    for ell in np.asarray(scene.ellipsoids, dtype=np.float64).reshape(-1, 6):
        if near_z - ell[5] < ell[2] < far_z + ell[5]:
            _render_ellipsoid(static, ell, origin, dx, dy, dz)
    is_moving = moving < static
    depth = np.minimum(static, moving)
    depth[~(depth <= MAX_DEPTH)] = 0.0
    # KITTI stores 1/256 m; quantising keeps PNG round trips exact.
    depth *= 256.0
    np.rint(depth, out=depth)
    depth *= 1.0 / 256.0
    return depth, is_moving & (depth > 0)


# ----------------------------------------------------------------------------- dataset
class SyntheticStreets(DepthDataset):
    """Built-in procedural street depth at KITTI's geometry; needs no download.

    Parameters
    ----------
    n : int
        Number of frames, 1 to :data:`MAX_SYNTHETIC_FRAMES` (an integer: floats, bools and
        strings are refused, not truncated).
    seed : int
        A non-negative integer (a float or bool is refused, not truncated).
        Frame ``i`` depends only on ``(seed, i)`` (and the constructor options), so any
        order, subset or process gives the same frames.
    frame_shape : (int, int)
        ``(H, W)``, each at least 8, at most
        :data:`~inpaintenv.conventions.MAX_FRAME_PIXELS` pixels in all; the principal point is placed as for a bottom-centre crop of the
        raw 1242x375 KITTI image, like :class:`KittiDepth` does.
    kind : {"groundtruth", "velodyne_raw", "dense"}
        Semi-dense accumulated ground truth (11 scans), one 64-beam scan, or the dense
        truth.
    frames_per_drive : int
        Consecutive frames sharing one street (the ego moves ~1 m per frame); they
        share a group so splits never separate them.
    input : {"map", "scan"}
        What a method is given (:mod:`inpaintenv.data.inputs`). ``"scan"`` (with
        ``kind="groundtruth"``): the frame's ``"velodyne_raw"`` scan, simulated from the same
        render as its ground truth (the frames of ``kind="velodyne_raw"`` and ``"groundtruth"``).

    Examples
    --------
    >>> ds = SyntheticStreets(n=16, seed=0)
    >>> ds[0].shape, len(set(ds.groups))
    ((352, 1216), 2)
    """

    def __init__(
        self,
        n: int = 64,
        seed: int = 0,
        frame_shape: tuple[int, int] = (352, 1216),
        kind: str = "groundtruth",
        frames_per_drive: int = 8,
        input: str = "map",
    ):
        # Integers only, never coerced: int("abc") failed obscurely, int(0.9) would quietly
        # give seed 0's frames under another name; bounded so that a typo cannot ask for gigabytes.
        self.n = check_int(n, "n", minimum=1, upper=MAX_SYNTHETIC_FRAMES + 1)
        self.frames_per_drive = check_int(frames_per_drive, "frames_per_drive", minimum=1)
        if kind not in _KINDS:
            raise InvalidInputError(f"kind must be one of {_KINDS}, got {kind!r}")
        self.input_kind = check_input_kind(input)
        if input_kind(input).separate and kind != "groundtruth":
            raise InvalidInputError(f"input={input!r} pairs a scan with its ground truth: kind must be 'groundtruth', "
                                    f"got {kind!r}")
        self.frame_shape = check_frame_shape(frame_shape, "frame_shape")
        self.seed, self.kind = check_seed(seed, "seed"), kind
        self.camera = Camera(self.frame_shape)
        drive = np.arange(self.n) // self.frames_per_drive
        self.groups = np.asarray([f"synthetic_s{self.seed}_drive_{d:04d}" for d in drive])
        self.frame_ids = [f"{g}/image_02/{i % self.frames_per_drive:010d}" for i, g in enumerate(self.groups)]

    def _scene(self, drive: int) -> Scene:
        return _cached_scene(self.seed, drive, self.frames_per_drive)

    def _render(self, index: int) -> tuple[np.ndarray, np.ndarray, float, np.random.Generator]:
        """Dense depth, moving-object mask, ego speed and the rng the samplings of frame ``index`` draw from."""
        drive, k = divmod(index, self.frames_per_drive)
        scene = self._scene(drive)
        rng = np.random.default_rng([self.seed, index, 1])
        depth, moving = render_dense(scene, k, self.camera, yaw_jitter=np.deg2rad(rng.uniform(-0.3, 0.3)))
        return depth, moving, scene.speed, rng

    def _load(self, index: int) -> np.ndarray:
        depth, moving, speed, rng = self._render(index)
        if self.kind == "dense":
            return depth
        if self.kind == "velodyne_raw":
            return single_scan(depth, self.camera, rng)
        return accumulated_scans(depth, moving, self.camera, speed, rng)

    def _load_scan(self, index: int) -> np.ndarray:
        depth, _, _, rng = self._render(index)
        return single_scan(depth, self.camera, rng)

    def _scan_calibration(self, index: int) -> tuple[Calibration, float | None]:
        return lidar_calibration(self.camera), 0.0  # the simulated lasers sit at the LiDAR's origin

    def _load_scan_pair(self, index: int) -> tuple[np.ndarray, np.ndarray]:
        # One render; the scan draws from a copy of the rng, so each equals its own kind's frame.
        depth, moving, speed, rng = self._render(index)
        scan = single_scan(depth, self.camera, copy.deepcopy(rng))
        return scan, accumulated_scans(depth, moving, self.camera, speed, rng)

    def _summary_fields(self) -> dict:
        return {"seed": self.seed, "kind": self.kind, "input": self.input_kind}

    def __repr__(self) -> str:
        return (
            f"SyntheticStreets(n={self.n}, seed={self.seed}, kind={self.kind!r}, "
            f"frame_shape={self.frame_shape}, frames_per_drive={self.frames_per_drive}"
            f"{', input=' + repr(self.input_kind) if self.input_kind != 'map' else ''})"
        )


@lru_cache(maxsize=16)
def _cached_scene(seed: int, drive: int, frames_per_drive: int) -> Scene:
    return build_scene(seed, drive, length=frames_per_drive * 1.3)
