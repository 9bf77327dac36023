"""The default for both input kinds: each frame routed by its measured density or by ``input``."""

from __future__ import annotations

import numpy as np
import pytest

from estimators.classical import HarmonicInpainter, NearestInpainter
from estimators.learned._routed import (LINE_SHARE, POINTS_SPACING, SCAN_DENSITY, SPARSE_SPACING, InputRoutedInpainter,
                                       OnFirstUse, close_gap_share, measured_density, row_spacing, scan_spacing)
from inpaintenv.data import SyntheticStreets
from inpaintenv.data.inputs import method_input
from inpaintenv.exceptions import InpaintenvError
from inpaintenv.masks import get_protocol

SHAPE = (64, 192)


def _inputs(kind: str, protocol: str, n: int = 3) -> np.ndarray:
    frames = SyntheticStreets(n=n, seed=1, frame_shape=SHAPE, input=kind)
    holes = get_protocol(protocol).masks(SHAPE, 0, range(n))
    return method_input(frames.load_input_batch(range(n)), holes, kind)


def _router(**kw) -> InputRoutedInpainter:
    return InputRoutedInpainter(map_method=NearestInpainter(), scan_method=HarmonicInpainter(),
                                scan_name="harmonic", map_name="nearest", **kw)


@pytest.mark.parametrize("protocol", ["rect-v1", "mixed-v1", "lidar-dropout-v1"])
def test_synthetic_maps_and_scans_go_to_their_method(protocol):
    est = _router()
    scans, maps = _inputs("scan", "densify-v1"), _inputs("map", protocol)
    assert all(measured_density(np.nan_to_num(x)) <= SCAN_DENSITY for x in scans)
    assert all(est.choose(x) == "harmonic" for x in scans)
    assert all(est.choose(x) == "nearest" for x in maps)
    both = np.concatenate([scans[:1], maps[:1]])
    out = est.predict(both)
    assert est.routed_to_ == ["harmonic", "nearest"]
    np.testing.assert_array_equal(out[0], HarmonicInpainter().predict(both[0]))
    np.testing.assert_array_equal(out[1], NearestInpainter().predict(both[1]))


def test_an_explicit_input_overrides_the_density():
    maps = _inputs("map", "rect-v1")
    est = _router(input="scan")
    est.predict(maps)
    assert est.routed_to_ == ["harmonic"] * len(maps)


@pytest.mark.parametrize("bad", [{"input": "lidar"}, {"threshold": 1.5}, {"threshold": True}])
def test_bad_parameters_are_one_clear_error(bad):
    with pytest.raises(InpaintenvError, match="input|threshold"):
        _router(**bad).predict(_inputs("scan", "densify-v1", 1))


def test_pretrained_fills_a_scan_with_the_scan_default_and_a_map_with_the_release():
    pytest.importorskip("torch")
    from inpaintenv.methods.learned import DEFAULT_RELEASE, SCAN_DEFAULT
    from inpaintenv.methods.registry import make_method

    est = make_method("pretrained")
    assert est.choose(_inputs("scan", "densify-v1", 1)[0]) == SCAN_DEFAULT
    assert est.choose(_inputs("map", "rect-v1", 1)[0]) == DEFAULT_RELEASE


def test_the_scan_route_is_the_registered_scan_default():
    pytest.importorskip("torch")
    from inpaintenv.methods.learned import SCAN_DEFAULT
    from inpaintenv.methods.registry import make_method

    est = make_method("pretrained")
    assert type(est.scan_method) is type(make_method(SCAN_DEFAULT))
    assert est.scan_method.get_params() == make_method(SCAN_DEFAULT).get_params()


def _lines(every: int, shape=SHAPE) -> np.ndarray:
    """A synthetic scan: a sloped ground's depth on every ``every``-th row (a LiDAR's lines) and every 4th
    column (its points along a line), NaN elsewhere: at most 1/12 of the pixels, as sparse as a scan."""
    depth = np.broadcast_to(np.linspace(40.0, 5.0, shape[0], dtype=np.float32)[:, None], shape).copy()
    depth[np.arange(shape[0]) % every != 0] = np.nan
    depth[:, np.arange(shape[1]) % 4 != 0] = np.nan
    return depth


def test_scan_spacing_follows_the_lines_not_a_hole():
    dense = _lines(3)
    assert scan_spacing(np.nan_to_num(dense)) == 3.0
    assert scan_spacing(np.nan_to_num(_lines(12))) == 12.0  # every 4th line kept: 4x the spacing
    holed = dense.copy()
    holed[10:50, 40:150] = np.nan  # a large hole: one long gap per column it covers
    assert scan_spacing(np.nan_to_num(holed)) == 3.0
    one_row = np.zeros((8, 8), np.float32)
    one_row[3] = 5.0
    assert scan_spacing(one_row) == np.inf and scan_spacing(np.zeros((8, 8))) == np.inf


def test_a_scan_sparser_than_the_gate_falls_back_to_the_sparse_route():
    dense, sparse = _lines(3), _lines(3 * 8)  # 8x fewer lines: spacing 24 > SPARSE_SPACING
    assert scan_spacing(np.nan_to_num(sparse)) > SPARSE_SPACING >= scan_spacing(np.nan_to_num(dense))
    maps = _inputs("map", "rect-v1", 1)
    est = _router(sparse_method=NearestInpainter(), sparse_name="nearest-sparse")
    both = np.stack([dense, sparse])
    out = est.predict(np.concatenate([both, maps]))
    assert est.routed_to_ == ["harmonic", "nearest-sparse", "nearest"]
    assert est.routed_kinds_ == ["scan", "sparse", "map"]
    np.testing.assert_array_equal(out[0], HarmonicInpainter().predict(dense))
    np.testing.assert_array_equal(out[1], NearestInpainter().predict(sparse))
    # Told it is a scan, the gate still looks at its spacing; told it is a map, never.
    assert est.set_params(input="scan").choose(sparse) == "nearest-sparse"
    assert est.set_params(input="map").choose(sparse) == "nearest"
    # Without a sparse route every scan takes the scan route, however sparse.
    assert _router().choose(sparse) == "harmonic"
    # The threshold is the parameter's: raised above the spacing, the same scan is no longer sparse.
    assert _router(sparse_method=NearestInpainter(), sparse_spacing=30.0).choose(sparse) == "harmonic"


def test_scattered_points_stay_with_the_scan_route_however_sparse():
    """A tenth of a dense scan's points, dropped at random, is as sparse as 8 beams' lines but not a LiDAR's lines."""
    dense = _lines(3)
    scattered = np.where(np.random.default_rng(0).random(dense.shape) < 0.1, dense, np.nan)
    assert scan_spacing(np.nan_to_num(scattered)) > SPARSE_SPACING
    assert close_gap_share(np.nan_to_num(scattered)) >= LINE_SHARE > close_gap_share(np.nan_to_num(_lines(24)))
    est = _router(sparse_method=NearestInpainter(), sparse_name="nearest-sparse")
    assert est.choose(scattered) == "harmonic" and est.choose(_lines(24)) == "nearest-sparse"


def _scattered(share: float, seed: int = 0) -> np.ndarray:
    """A dense synthetic scan (every 3rd line, every 4th column: 4 px apart along a line, as KITTI's 3 px)
    with a random ``share`` of its points kept."""
    dense = _lines(3)
    return np.where(np.random.default_rng(seed).random(dense.shape) < share, dense, np.nan)


def test_row_spacing_follows_the_points_along_a_line_not_the_lines():
    assert row_spacing(np.nan_to_num(_lines(3))) == 4.0
    assert row_spacing(np.nan_to_num(_lines(24))) == 4.0  # fewer lines, the same points along each
    holed = np.nan_to_num(_lines(3))
    holed[10:50, 40:150] = 0.0  # a large hole: one long gap per row it covers
    assert row_spacing(holed) == 4.0
    assert row_spacing(np.nan_to_num(_scattered(0.1))) > POINTS_SPACING > row_spacing(np.nan_to_num(_scattered(0.25)))
    one_column = np.zeros((8, 8), np.float32)
    one_column[:, 3] = 5.0
    assert row_spacing(one_column) == np.inf


def test_a_tenth_of_the_points_takes_the_points_route_and_lines_do_not():
    """Scattered points far apart along the lines go to points_method, before the sparse route looks at them;
    a LiDAR's lines, however few, and a quarter of the points do not."""
    tenth, quarter, eight = _scattered(0.1), _scattered(0.25), _lines(24)
    est = _router(sparse_method=NearestInpainter(), sparse_name="nearest-sparse",
                  points_method=NearestInpainter(), points_name="nearest-points")
    out = est.predict(np.stack([tenth, quarter, eight, _lines(3)]))
    assert est.routed_kinds_ == ["points", "scan", "sparse", "scan"]
    assert est.routed_to_ == ["nearest-points", "harmonic", "nearest-sparse", "harmonic"]
    np.testing.assert_array_equal(out[0], NearestInpainter().predict(tenth))
    # Without a points route the same frame takes the route it took before; the threshold is the parameter's.
    assert _router().choose(tenth) == "harmonic"
    assert est.set_params(points_spacing=1000.0).kind(tenth) != "points"
    assert est.set_params(points_spacing=POINTS_SPACING, input="map").choose(tenth) == "nearest"


def test_a_scattered_point_scan_borrows_no_interval():
    est = InputRoutedInpainter(map_method=_WithInterval(), scan_method=_WithInterval(), points_method=HarmonicInpainter(),
                               points_name="harmonic-points", intervals=lambda name, method: _WithInterval())
    with pytest.raises(InpaintenvError, match="scattered-point scan.*harmonic-points none is calibrated on such scans"):
        est.predict_interval(_scattered(0.1)[None])


@pytest.mark.parametrize("bad", [{"points_spacing": 0.0}, {"points_method": "harmonic"}, {"points_name": 3}])
def test_bad_points_route_parameters_are_one_clear_error(bad):
    with pytest.raises(InpaintenvError, match="points_"):
        _router(**bad).predict(_lines(3)[None])


@pytest.mark.parametrize("bad", [{"sparse_spacing": 0.0}, {"sparse_spacing": np.inf}, {"sparse_method": "harmonic"},
                                 {"sparse_name": 3}])
def test_bad_sparse_route_parameters_are_one_clear_error(bad):
    with pytest.raises(InpaintenvError, match="sparse_"):
        _router(**bad).predict(_lines(3)[None])


def test_a_sparse_scan_has_no_interval_unless_its_route_gives_one():
    est = InputRoutedInpainter(map_method=_WithInterval(), scan_method=_WithInterval(), sparse_method=HarmonicInpainter(),
                               sparse_name="harmonic")
    low, high = est.predict_interval(_lines(3), coverage=0.9)
    np.testing.assert_allclose(high - low, 2.0, atol=1e-5)
    with pytest.raises(InpaintenvError, match="no calibrated interval for a single sparse scan yet: its route harmonic"):
        est.predict_interval(_lines(24), coverage=0.9)


def test_pretrained_fills_a_sparse_scan_with_the_sparse_default():
    from inpaintenv.methods.learned import SCAN_DEFAULT, SPARSE_DEFAULT
    from inpaintenv.methods.registry import make_method

    from estimators.learned import OnFirstUse, load_default, load_release

    # the sparse release, loaded when a sparse scan first takes the route
    assert SPARSE_DEFAULT == "kitti-sparse-v1" and load_default().get_params(deep=False)["sparse_method"] == OnFirstUse(
        load_release, SPARSE_DEFAULT)
    est = make_method("pretrained")
    sparse = _lines(24)
    np.testing.assert_array_equal(est.predict(sparse), make_method(SPARSE_DEFAULT).predict(sparse))
    assert est.routed_to_ == [SPARSE_DEFAULT] and est.choose(_lines(3)) == SCAN_DEFAULT


class _Counted:
    """A route's factory that counts the methods it made."""

    def __init__(self, cls):
        self.cls, self.made = cls, 0

    def __call__(self):
        self.made += 1
        return self.cls()


def test_a_route_given_on_first_use_is_made_when_a_frame_first_takes_it():
    scans, maps = _inputs("scan", "densify-v1", 2), _inputs("map", "rect-v1", 2)
    map_factory, scan_factory = _Counted(NearestInpainter), _Counted(HarmonicInpainter)
    est = InputRoutedInpainter(map_method=OnFirstUse(map_factory), scan_method=OnFirstUse(scan_factory))
    assert est.choose(maps[0]) == "map" and (map_factory.made, scan_factory.made) == (0, 0)
    np.testing.assert_array_equal(est.predict(scans), HarmonicInpainter().predict(scans))
    assert (map_factory.made, scan_factory.made) == (0, 1)
    expected = np.concatenate([NearestInpainter().predict(maps), HarmonicInpainter().predict(scans)])
    np.testing.assert_array_equal(est.predict(np.concatenate([maps, scans])), expected)
    assert (map_factory.made, scan_factory.made) == (1, 1)
    assert type(est.map_method) is NearestInpainter and map_factory.made == 1


def test_threads_sharing_a_router_make_each_route_once():
    from joblib import Parallel, delayed

    factory = _Counted(HarmonicInpainter)
    est = InputRoutedInpainter(map_method=NearestInpainter(), scan_method=OnFirstUse(factory))
    scans = _inputs("scan", "densify-v1", 1)
    outs = Parallel(n_jobs=4, prefer="threads")(delayed(est.predict)(scans) for _ in range(8))
    assert factory.made == 1
    for out in outs:
        np.testing.assert_array_equal(out, outs[0])


def test_a_router_on_first_use_keeps_its_parameters_clones_and_pickles():
    import pickle

    from sklearn.base import clone

    scans = _inputs("scan", "densify-v1", 1)
    given = OnFirstUse(HarmonicInpainter)
    est = InputRoutedInpainter(map_method=OnFirstUse(NearestInpainter), scan_method=given, scan_name="harmonic")
    params = est.get_params(deep=False)
    assert set(params) == {"map_method", "scan_method", "input", "threshold", "scan_name", "map_name",
                           "intervals", "sparse_method", "sparse_spacing", "sparse_name", "points_method",
                           "points_spacing", "points_name"}
    assert params["scan_method"] is given and "OnFirstUse(HarmonicInpainter)" in repr(est)
    unused = pickle.loads(pickle.dumps(est))
    expected = est.predict(scans)
    assert est.get_params(deep=False)["scan_method"] is given  # made, but the parameter is as given
    assert "scan_method__keep_observed" in est.get_params(deep=True)
    for other in (clone(est), unused, pickle.loads(pickle.dumps(est))):
        np.testing.assert_array_equal(other.predict(scans), expected)
        assert other.routed_to_ == ["harmonic"]
    est.set_params(scan_method=NearestInpainter())
    np.testing.assert_array_equal(est.predict(scans), NearestInpainter().predict(scans))


def test_pretrained_loads_the_map_release_only_for_a_map(monkeypatch):
    """A run on scans never loads the map release (nor one on maps the scan release)."""
    pytest.importorskip("torch")
    from estimators.learned import _releases
    from inpaintenv.methods.learned import DEFAULT_RELEASE, SCAN_DEFAULT

    loaded = []
    real = _releases.load_release
    monkeypatch.setattr(_releases, "load_release", lambda name, **kw: loaded.append(name) or real(name, **kw))
    est = _releases.load_default()
    assert est.choose(_inputs("map", "rect-v1", 1)[0]) == DEFAULT_RELEASE and loaded == []
    est.predict(_inputs("scan", "densify-v1", 1))
    assert loaded == [SCAN_DEFAULT]
    _releases.load_default(input="map").predict(_inputs("map", "rect-v1", 1))
    assert loaded == [SCAN_DEFAULT, DEFAULT_RELEASE]


def test_pretrained_without_a_default_release_is_refused_when_built(monkeypatch):
    pytest.importorskip("torch")
    from estimators.learned import _releases

    monkeypatch.setattr(_releases, "shipped", lambda: {})
    with pytest.raises(InpaintenvError, match="no shipped release 'kitti-"):
        _releases.load_default()


def _official_scan_sets(kitti_root):
    from inpaintenv.data import KittiDepth

    sets = {}
    if (kitti_root / "depth_selection").is_dir():
        sets["val_selection"] = KittiDepth(kitti_root, split="val_selection", camera="both", input="scan")
    try:
        sets["0001"] = KittiDepth(kitti_root, split="train", camera="both", input="scan",
                                  drives=["2011_09_26_drive_0001_sync"])
    except (FileNotFoundError, ValueError):
        pass
    if not sets:
        pytest.skip("the KITTI slice has no official frames with a scan")
    return sets


def _rmse_per_frame(pred, gt, scored):
    return np.array([np.sqrt(np.mean((p[m] - g[m]) ** 2)) if m.any() else np.nan for p, g, m in zip(pred, gt, scored)])


#: rect-v1 seeds of the hole task on the official scans (each (seed, frame) one unit).
HOLE_SEEDS = (0, 1, 2)


@pytest.fixture(scope="module")
def official_tasks(kitti_root):
    """KITTI's official frames with a scan (val_selection, drive 0001), per ``(set, task)``: the
    method input, the ground truth and the pixels scored. ``densify-v1``: the scan, scored on
    the ground-truth pixels it did not measure; ``rect-v1``: its holes cut out of the scan
    (each seed of :data:`HOLE_SEEDS`), scored in the holes."""
    tasks = {}
    for set_name, frames in _official_scan_sets(kitti_root).items():
        idx = list(range(0, len(frames), max(1, len(frames) // 6)))  # about 6 frames a set, spread over it
        scans, gt = frames.load_pairs(idx)
        x = method_input(scans, np.zeros(scans.shape, bool), "scan")
        tasks[set_name, "densify-v1"] = (x, gt, (gt > 0) & np.isnan(x))
        holes = np.concatenate([get_protocol("rect-v1").masks(gt.shape[1:], seed, idx) for seed in HOLE_SEEDS])
        gt_hole = np.tile(gt, (len(HOLE_SEEDS), 1, 1))
        x_hole = method_input(np.tile(scans, (len(HOLE_SEEDS), 1, 1)), holes, "scan")
        tasks[set_name, "rect-v1"] = (x_hole, gt_hole, holes & (gt_hole > 0))
    return tasks


@pytest.fixture(scope="module")
def pretrained_on_official(official_tasks):
    """``pretrained``'s scan route name, and per ``(set, task)`` its per-frame RMSE and each frame's route."""
    pytest.importorskip("torch")
    from inpaintenv.methods.registry import make_method

    est = make_method("pretrained")
    scores = {}
    for key, (x, gt, scored) in official_tasks.items():
        scores[key] = (_rmse_per_frame(est.predict(x), gt, scored), est.routed_to_)
    return est.scan_name, scores


@pytest.fixture(scope="module")
def classical_on_official(official_tasks):
    """Every classical fill of every missing pixel (but ``constant``): its per-frame RMSE per ``(set, task)``,
    each predicted once, its frames in threads (each frame is filled alone: bit-identical to one thread,
    tests/estimators/test_common.py::test_n_jobs_gives_identical_results)."""
    from inpaintenv.methods.classical import CLASSICAL_METHODS
    from inpaintenv.methods.registry import make_method

    rivals = [name for name, _, kwargs, _ in CLASSICAL_METHODS
              if kwargs.get("fill", "invalid") == "invalid" and name != "constant"]
    return {name: {key: _rmse_per_frame(make_method(name, n_jobs=-1).predict(x), gt, scored)
                   for key, (x, gt, scored) in official_tasks.items()} for name in rivals}


@pytest.mark.kitti
def test_pretrained_routes_every_official_scan_as_a_scan(pretrained_on_official):
    scan_name, scores = pretrained_on_official
    for key, (rmse, routes) in scores.items():
        assert routes == [scan_name] * len(rmse), key


@pytest.mark.kitti
def test_pretrained_is_no_worse_than_harmonic_on_any_val_selection_frame(pretrained_on_official,
                                                                          classical_on_official):
    key = ("val_selection", "densify-v1")
    if key not in pretrained_on_official[1]:
        pytest.skip("the KITTI slice has no depth_selection/")
    ours = pretrained_on_official[1][key][0]
    assert (ours <= classical_on_official["harmonic"][key] + 1e-6).all()


@pytest.mark.kitti
def test_pretrained_densifies_the_official_scans_no_worse_than_any_classical_fill(pretrained_on_official,
                                                                                  classical_on_official):
    """On each set, the mean RMSE over frames on the ground-truth pixels the scan did not measure."""
    ours = {key: rmse.mean() for key, (rmse, _) in pretrained_on_official[1].items() if key[1] == "densify-v1"}
    worse = [(key, name, ours[key], theirs[key].mean()) for name, theirs in classical_on_official.items()
             for key in ours if not ours[key] <= theirs[key].mean() + 1e-6]
    assert ours and not worse


@pytest.mark.kitti
def test_pretrained_fills_holes_cut_into_the_official_scans_better_than_any_classical_fill(pretrained_on_official,
                                                                                           classical_on_official):
    """On each set, with rect-v1's holes cut out of the scan: the mean hole RMSE over frames and seeds."""
    ours = {key: np.nanmean(rmse) for key, (rmse, _) in pretrained_on_official[1].items() if key[1] == "rect-v1"}
    worse = [(key, name, ours[key], np.nanmean(theirs[key])) for name, theirs in classical_on_official.items()
             for key in ours if not ours[key] < np.nanmean(theirs[key])]
    assert ours and not worse


class _WithInterval(NearestInpainter):
    """A map route that gives an interval: its prediction +- 1 m."""

    def predict_interval(self, X, coverage=0.9, prediction=None):
        pred = self.predict(X) if prediction is None else prediction
        return pred - 1.0, pred + 1.0


def test_an_interval_is_asked_of_each_frames_route_and_a_route_without_one_is_named():
    est = InputRoutedInpainter(map_method=_WithInterval(), scan_method=HarmonicInpainter(),
                               scan_name="harmonic", map_name="nearest")
    maps, scans = _inputs("map", "rect-v1", 2), _inputs("scan", "densify-v1", 1)
    low, high = est.predict_interval(maps, coverage=0.9)
    pred = NearestInpainter().predict(maps)
    np.testing.assert_allclose(low, pred - 1.0)
    np.testing.assert_allclose(high, pred + 1.0)
    with pytest.raises(InpaintenvError, match="no calibrated interval for a single scan yet: its route harmonic"):
        est.predict_interval(np.concatenate([maps, scans]), coverage=0.9)


class _OneMetre:
    """An interval of 1 m either side around any method; counts the ones it made and names their route."""

    def __init__(self):
        self.made = []

    def __call__(self, name, method):
        self.made.append(name)
        return _WithStd(method)


class _WithStd:
    def __init__(self, method):
        self.method = method

    def predict(self, X, return_std=False):
        pred = self.method.predict(X)
        return (pred, np.where(np.isnan(X), 0.5, 0.0).astype(np.float32)) if return_std else pred

    def predict_interval(self, X, coverage=0.9):
        pred = self.method.predict(X)
        return pred - 1.0, pred + 1.0


def test_a_route_without_an_interval_gets_one_from_intervals_once_and_return_std_routes_per_frame():
    intervals = _OneMetre()
    est = InputRoutedInpainter(map_method=_WithInterval(), scan_method=OnFirstUse(HarmonicInpainter),
                               scan_name="harmonic", map_name="nearest", intervals=intervals)
    maps, scans = _inputs("map", "rect-v1", 2), _inputs("scan", "densify-v1", 1)
    batch = np.concatenate([maps, scans])
    low, high = est.predict_interval(batch, coverage=0.9)
    est.predict_interval(scans, coverage=0.8)
    assert intervals.made == ["harmonic"]  # the map route has its own; the scan route's made once
    pred = est.predict(batch)
    np.testing.assert_array_equal(low[2], pred[2] - 1.0)
    np.testing.assert_array_equal(high[:2], pred[:2] + 1.0)
    with pytest.raises(InpaintenvError, match="route nearest .* gives no std"):
        est.predict(batch, return_std=True)  # _WithInterval has no return_std
    same, std = est.predict(scans, return_std=True)
    np.testing.assert_array_equal(same, pred[2:])
    assert est.routed_to_ == ["harmonic"] and (std[np.isnan(scans)] == 0.5).all() and (std[~np.isnan(scans)] == 0).all()
    est.set_params(scan_method=NearestInpainter())  # a route set anew gets its interval anew
    est.predict_interval(scans)
    assert intervals.made == ["harmonic", "harmonic"]
    with pytest.raises(InpaintenvError, match="intervals must be None or a callable"):
        est.set_params(intervals="shipped").predict(scans)


def test_pretrained_intervals_routes_like_pretrained():
    pytest.importorskip("torch")
    from inpaintenv.methods.registry import is_learned, make_method

    est = make_method("pretrained-intervals")
    assert is_learned("pretrained-intervals")
    assert est.choose(_inputs("scan", "densify-v1", 1)[0]) == est.scan_name
    assert hasattr(est.interval_method("map"), "predict_interval")
