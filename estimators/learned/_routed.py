"""InputRoutedInpainter: one method for both input kinds, each frame filled by the method of its kind.

A single LiDAR scan (KITTI's ``velodyne_raw``) measures about 4-5 % of a frame's pixels; a
ground-truth map with holes cut into it keeps 12 % or more of the rows it spans. The
method that fills one well is not the one that fills the other (the map releases were
never trained on a scan and are worse than ``harmonic`` on one), so ``pretrained`` routes
each frame by its kind: given as ``input``, or told from its measured density. A scan much
sparser than the 64-beam scans the scan route was trained on (a 32-, 16- or 8-beam LiDAR: told
from :func:`scan_spacing` and :func:`close_gap_share`) goes to ``sparse_method`` when one is given: there
the scan release's learned blend is worse than the classical fills, so ``pretrained`` falls
back to the classical ``harmonic``. A scan of points scattered far apart along its lines (a tenth
of a scan's points: told from :func:`row_spacing`) goes to ``points_method`` when one is given.

>>> from estimators.learned import InputRoutedInpainter                   # doctest: +SKIP
>>> est = InputRoutedInpainter(map_method=load_release(), scan_method=HarmonicInpainter())
>>> est.choose(scan_with_nan)                                            # "scan"

A route may be given as :class:`OnFirstUse`: its method is made when the route first fills a
frame, so ``pretrained`` loads the map release only for a map and the scan release only for a scan.
A route without an interval of its own gets one from ``intervals`` (``pretrained``'s: the
calibration shipped for the route's name), wrapped around the route's method when first asked.
"""

from __future__ import annotations

import inspect
import threading
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
from sklearn.utils.validation import check_is_fitted

from inpaintenv.exceptions import InvalidInputError, InvalidTypeError

from .._constraints import Check, ConstrainedParams, InstanceOf, Options, Real
from ..base import BaseInpainter, check_inpaint_input

__all__ = ["INPUT_CHOICES", "LINE_SHARE", "POINTS_SPACING", "SCAN_DENSITY", "SPARSE_SPACING", "InputRoutedInpainter",
           "OnFirstUse", "close_gap_share", "measured_density", "row_spacing", "scan_spacing"]

#: Measured share of the rows a frame's measurements span at or below which it is a scan.
#: On the KITTI slice (scripts: experiments/scan_release.py --density) single scans span
#: 0.042-0.072 and maps with any protocol's holes 0.12-0.43; synthetic scans 0.04-0.05.
SCAN_DENSITY = 0.10
#: :func:`scan_spacing` (pixels) above which a scan is sparser than a 64-beam one. Chosen with one
#: recording day left out (experiments/scan_lodo.py density): KITTI's 64-beam scans, with or
#: without rect-v1's holes, measure 8-12 px, the same scans with every 2nd ring or half the
#: points kept 16-21 px, sparser ones more; 14 lies between them on every pair of days.
SPARSE_SPACING = 14.0
#: :func:`close_gap_share` below which a sparse scan is a LiDAR's lines (fewer beams), not scattered
#: points. On the KITTI slice's scans with every 2nd, 4th or 8th ring kept it is at most 0.019; with
#: a random 50/25/10 % of the points kept, 0.017-0.10 (0.034 and more at 25 % and 50 %); on 64-beam
#: scans 0.10-0.19. Scattered points stay with the scan route, whose classical mean near the points
#: is the strongest fill there; a LiDAR's sparse lines take the sparse route.
LINE_SHARE = 0.025
#: :func:`row_spacing` (pixels) above which a scan's points lie far apart along its lines (scattered
#: points, a tenth of a scan's or fewer). On the KITTI slice (experiments/scan_lodo.py density's
#: frames, 2 per drive) a LiDAR's lines, 8 to 64 beams, with or without rect-v1's holes, measure
#: 3 px; a random 50 % of the points 4-5, 25 % 9-13, 10 % 28-71. Chosen with one recording day left
#: out, halfway between the largest 25 % and the smallest 10 % value of the other two days (20.0,
#: 20.5, 22.0): each separates its left-out day; this is 2011_09_30 and 2011_10_03's.
POINTS_SPACING = 20.0
#: The largest gap (pixels) :func:`close_gap_share` counts as close.
CLOSE_GAP = 4
#: What ``input`` may say: decide per frame, or every frame is of one kind.
INPUT_CHOICES = ("auto", "scan", "map")
#: The routes, in the order a batch is filled.
ROUTES = ("scan", "sparse", "points", "map")
#: How messages name each route's frames.
_KIND_WORDS = {"scan": "scan", "sparse": "sparse scan", "points": "scattered-point scan", "map": "map"}
# One lock for every router: a module's lock is never pickled or copied with an estimator, and
# making a route (loading a release) is rare enough that routers need not make theirs in parallel.
_MAKING = threading.Lock()


def _check_route(route: Any, name: str) -> None:
    """Accept a method with ``predict`` or an :class:`OnFirstUse`; anything else is one error naming ``name``."""
    if not isinstance(route, OnFirstUse) and not callable(getattr(route, "predict", None)):
        raise InvalidTypeError(f"{name} must be an inpainter (with predict) or an OnFirstUse, got {route!r}")


def _check_intervals(value: Any) -> None:
    """``intervals``: None or a callable ``(name, method) -> interval estimator``."""
    if not callable(value):
        raise InvalidTypeError(f"intervals must be None or a callable (route name, method) -> interval estimator, "
                               f"got {value!r}")


def measured_density(x: np.ndarray) -> float:
    """The share of measured (positive) pixels in the rows from the first to the last that has one.

    The rows a sensor reaches, not the whole frame: a frame's sky rows (no LiDAR return, no
    ground truth) would otherwise make a map with a large hole look as sparse as a scan.
    0.0 for a frame without any measurement.
    """
    measured = np.asarray(x) > 0
    rows = np.flatnonzero(measured.any(axis=1))
    if not len(rows):
        return 0.0
    return float(measured[rows[0] : rows[-1] + 1].mean())


def scan_spacing(x: np.ndarray) -> float:
    """The median gap (pixels) between vertically consecutive measurements of a column: how far apart a scan's lines lie.

    Counted per gap, not per pixel, so a hole cut into a scan (one long gap in each column it
    covers) barely moves it, while keeping every k-th laser ring or a k-th of the points
    multiplies it by about k. ``inf`` for a frame with no two measurements in any column.
    """
    gaps = _column_gaps(x)
    return float(np.median(gaps)) if len(gaps) else float("inf")


def row_spacing(x: np.ndarray) -> float:
    """The median gap (pixels) between horizontally consecutive measurements of a row: how far apart a line's points lie.

    A LiDAR's lines, however few, keep their points a few pixels apart along a line; points
    dropped at random from a scan spread them by about the share dropped. ``inf`` for a frame
    with no two measurements in any row.
    """
    measured = np.asarray(x) > 0
    rows, cols = np.nonzero(measured)  # row-major: each row's columns in order
    gaps = np.diff(cols)[rows[1:] == rows[:-1]]
    return float(np.median(gaps)) if len(gaps) else float("inf")


def close_gap_share(x: np.ndarray) -> float:
    """The share of :func:`scan_spacing`'s gaps of at most :data:`CLOSE_GAP` pixels (0.0 when there are none).

    A LiDAR's lines leave almost no such gap once rings are missing; points dropped at random
    from a scan leave many (two neighbours on one line both kept).
    """
    gaps = _column_gaps(x)
    return float(np.mean(gaps <= CLOSE_GAP)) if len(gaps) else 0.0


def _column_gaps(x: np.ndarray) -> np.ndarray:
    """Every gap (pixels) between vertically consecutive measurements (positive) of a column."""
    measured = np.asarray(x) > 0
    cols, rows = np.nonzero(measured.T)  # column-major: each column's rows in order
    return np.diff(rows)[cols[1:] == cols[:-1]]


class OnFirstUse:
    """A route's method, made by ``factory(*args, **kwargs)`` when the route first fills a frame.

    Picklable and copyable when ``factory`` is (a module-level function): a router that was
    never used pickles without any method in it.

    Parameters
    ----------
    factory : callable
        Returns the fitted method (e.g. :func:`~estimators.learned.load_release`).
    *args, **kwargs
        Its arguments.
    """

    def __init__(self, factory: Callable[..., Any], *args: Any, **kwargs: Any):
        self.factory = factory
        self.args = args
        self.kwargs = kwargs

    def make(self) -> Any:
        """The method: ``factory(*args, **kwargs)``, made anew at each call."""
        return self.factory(*self.args, **self.kwargs)

    def __eq__(self, other: object) -> bool:
        # Two promises of the same method are the same parameter (a clone's copy equals the original).
        if not isinstance(other, OnFirstUse):
            return NotImplemented
        return (self.factory, self.args, self.kwargs) == (other.factory, other.args, other.kwargs)

    def __hash__(self) -> int:
        return hash((self.factory, self.args, tuple(sorted(self.kwargs.items()))))

    def __repr__(self) -> str:
        given = [repr(a) for a in self.args] + [f"{k}={v!r}" for k, v in self.kwargs.items()]
        return f"OnFirstUse({', '.join([getattr(self.factory, '__name__', repr(self.factory)), *given])})"


def _route_attribute(kind: str) -> property:
    """``<kind>_method``: set, the route as given; read, its method (made now if given as :class:`OnFirstUse`)."""

    def read(self: InputRoutedInpainter) -> Any:
        return self._route(kind)

    def write(self: InputRoutedInpainter, value: Any) -> None:
        self.__dict__[f"_{kind}_given"] = value
        self.__dict__.pop(f"_{kind}_made", None)  # a route set anew is made anew
        self.__dict__.pop(f"_{kind}_interval", None)  # and its interval with it

    return property(read, write, doc=f"The method that fills a {kind} (made on first use if given as OnFirstUse).")


class InputRoutedInpainter(ConstrainedParams, BaseInpainter):
    """Fill each frame with ``scan_method`` if it is a single LiDAR scan, else ``map_method``;
    a scan sparser than ``sparse_spacing`` with ``sparse_method``, a scan of scattered points with
    ``points_method`` when one is given.

    Parameters
    ----------
    map_method : estimator or OnFirstUse
        Fills a ground-truth map with holes (a fitted inpainter); an :class:`OnFirstUse` is
        made when a map is first filled (reading ``map_method`` makes it too).
    scan_method : estimator or OnFirstUse
        Fills a single scan (every unmeasured pixel NaN); likewise.
    input : {"auto", "scan", "map"}, default "auto"
        ``"auto"``: each frame's kind from its :func:`measured_density` (at most
        ``threshold``: a scan); otherwise every frame is of that kind.
    threshold : float, default :data:`SCAN_DENSITY`
        The density that separates the kinds.
    sparse_method : estimator, OnFirstUse or None, default None
        Fills a scan whose :func:`scan_spacing` exceeds ``sparse_spacing`` and whose lines are a
        LiDAR's (a sensor with fewer beams than the scans ``scan_method`` knows; scattered points
        stay with ``scan_method``); None: every scan goes to ``scan_method``.
    sparse_spacing : float, default :data:`SPARSE_SPACING`
        The spacing (pixels) above which a scan is sparse.
    points_method : estimator, OnFirstUse or None, default None
        Fills a scan whose :func:`row_spacing` exceeds ``points_spacing`` (points scattered far
        apart along its lines, fewer than a 64-beam scan's) before any other scan route; None:
        such a scan goes to the sparse or scan route. Its interval is never borrowed from
        ``intervals`` (no calibration is made on such scans): only its method's own.
    points_spacing : float, default :data:`POINTS_SPACING`
        The spacing (pixels) along a line above which a scan's points are scattered.
    scan_name, map_name, sparse_name, points_name : str
        What :attr:`routed_to_` says for each route (e.g. ``"harmonic"``).
    intervals : callable or None, default None
        How a route whose method has no ``predict_interval`` gets an interval:
        ``intervals(name, method)`` (``name`` the route's ``scan_name``/``map_name``) returns
        an interval estimator around ``method`` (e.g.
        :class:`estimators.intervals.ShippedIntervals`: the calibration shipped for ``name``),
        made when the route is first asked for one; None: such a route has no interval.

    Attributes
    ----------
    routed_to_ : list of str
        After :meth:`predict`: per frame of the last call, the name of the method that filled it.
    routed_kinds_ : list of str
        After :meth:`predict`: per frame of the last call, its route (``"scan"``, ``"sparse"``, ``"points"``, ``"map"``).
    """

    # Its routes come fitted and fit trains nothing: checked as a pretrained model is, never refitted.
    _stateless = False
    map_method = _route_attribute("map")
    scan_method = _route_attribute("scan")
    sparse_method = _route_attribute("sparse")
    points_method = _route_attribute("points")

    def __init__(self, *, map_method: Any, scan_method: Any, input: str = "auto", threshold: float = SCAN_DENSITY,
                 scan_name: str = "scan", map_name: str = "map", intervals: Callable[[str, Any], Any] | None = None,
                 sparse_method: Any = None, sparse_spacing: float = SPARSE_SPACING, sparse_name: str = "sparse",
                 points_method: Any = None, points_spacing: float = POINTS_SPACING, points_name: str = "points"):
        self.map_method = map_method
        self.scan_method = scan_method
        self.input = input
        self.threshold = threshold
        self.scan_name = scan_name
        self.map_name = map_name
        self.intervals = intervals
        self.sparse_method = sparse_method
        self.sparse_spacing = sparse_spacing
        self.sparse_name = sparse_name
        self.points_method = points_method
        self.points_spacing = points_spacing
        self.points_name = points_name

    def get_params(self, deep: bool = True) -> dict[str, Any]:
        """The constructor's parameters, each route as given (an :class:`OnFirstUse` stays one).

        Parameters
        ----------
        deep : bool, default True
            Also each route's own parameters as ``map_method__<name>``: the routes are made
            for it (so ``set_params(map_method__tta=...)`` sets the made method); the routes
            themselves stay as given, as with ``deep=False``.

        Returns
        -------
        dict
            Parameter names mapped to their values.
        """
        routes = [f"{kind}_method" for kind in ROUTES]
        params = {name: getattr(self, name) for name in self._get_param_names() if name not in routes}
        for kind in ROUTES:
            # Deep or not, the route itself is as given (scikit-learn: the shallow parameters
            # are a part of the deep ones); only its own parameters need it made.
            params[f"{kind}_method"] = self.__dict__[f"_{kind}_given"]
            route = self._route(kind) if deep else None
            if route is not None and hasattr(route, "get_params") and not isinstance(route, type):
                params.update((f"{kind}_method__{k}", v) for k, v in route.get_params().items())
        return params

    def _route(self, kind: str) -> Any:
        """The method of route ``kind``: as given, or made from its :class:`OnFirstUse` once (under a lock,
        so threads sharing the router make it once)."""
        given, made = self.__dict__[f"_{kind}_given"], f"_{kind}_made"
        if not isinstance(given, OnFirstUse):
            return given
        if made not in self.__dict__:
            with _MAKING:
                if made not in self.__dict__:  # another thread may have made it meanwhile
                    self.__dict__[made] = given.make()
        return self.__dict__[made]

    def _routes(self, kinds: list[str]) -> Iterator[tuple[str, list[int], Any]]:
        """Each route that ``kinds`` (one per frame) uses: its kind, its frames and its method (made only now)."""
        for kind in ROUTES:
            pick = [i for i, k in enumerate(kinds) if k == kind]
            if pick:
                yield kind, pick, self._route(kind)

    _parameter_constraints: dict[str, list[Any]] = {
        "map_method": [Check(lambda route: _check_route(route, "map_method"))],
        "scan_method": [Check(lambda route: _check_route(route, "scan_method"))],
        "sparse_method": [None, Check(lambda route: _check_route(route, "sparse_method"))],
        "sparse_spacing": [Real(0, None, closed="neither")],
        "sparse_name": [InstanceOf(str, "a name (str)")],
        "points_method": [None, Check(lambda route: _check_route(route, "points_method"))],
        "points_spacing": [Real(0, None, closed="neither")],
        "points_name": [InstanceOf(str, "a name (str)")],
        "input": [Options(*INPUT_CHOICES)],
        "threshold": [Real(0, 1, closed="neither")],
        "scan_name": [InstanceOf(str, "a name (str)")],
        "map_name": [InstanceOf(str, "a name (str)")],
        "intervals": [None, Check(_check_intervals)],
    }

    def _param_value(self, name: str) -> Any:
        # A route is checked as given: reading it would make (load) an OnFirstUse route.
        return self.__dict__[f"_{name[:-len('_method')]}_given"] if name in (f"{k}_method" for k in ROUTES) \
            else getattr(self, name)

    def kind(self, x: np.ndarray) -> str:
        """``"scan"``, ``"sparse"``, ``"points"`` or ``"map"``: the route of one ``(H, W)`` frame (NaN = to fill).

        ``"points"`` only with a ``points_method``: a scan whose :func:`row_spacing` exceeds
        ``points_spacing`` (points scattered along its lines, not a LiDAR's lines).

        ``"sparse"`` only with a ``sparse_method``: a scan (``input="scan"``, or told from its
        density) whose :func:`scan_spacing` exceeds ``sparse_spacing`` and whose lines are a
        LiDAR's (:func:`close_gap_share` below :data:`LINE_SHARE`), not scattered points.
        """
        self._check_params_once()
        measured = np.nan_to_num(x, nan=0.0)
        if self.input == "map" or (self.input == "auto" and measured_density(measured) > float(self.threshold)):
            return "map"
        if self.__dict__["_points_given"] is not None and np.isfinite(spread := row_spacing(measured)) \
                and spread > float(self.points_spacing):
            return "points"
        if self.__dict__["_sparse_given"] is not None and scan_spacing(measured) > float(self.sparse_spacing) \
                and close_gap_share(measured) < LINE_SHARE:
            return "sparse"
        return "scan"

    def name_of(self, kind: str) -> str:
        """What :attr:`routed_to_` says for route ``kind``."""
        return {"scan": self.scan_name, "sparse": self.sparse_name, "points": self.points_name, "map": self.map_name}[kind]

    def choose(self, x: np.ndarray) -> str:
        """The name of the method that fills frame ``x`` (``scan_name``, ``sparse_name``, ``points_name`` or ``map_name``)."""
        return self.name_of(self.kind(x))

    def __sklearn_is_fitted__(self) -> bool:
        return True  # each route checks its own fit when it predicts

    def _fit(self, dataset: Any) -> None:
        raise InvalidInputError("InputRoutedInpainter trains nothing: fit its map_method and scan_method instead")

    def _predict_batch(self, X: np.ndarray) -> np.ndarray:
        kinds = [self.kind(frame) for frame in X]
        out = np.empty(X.shape, np.float32)
        for _, pick, method in self._routes(kinds):
            out[pick] = method.predict(X[pick])
        self.routed_to_ = [self.name_of(k) for k in kinds]
        self.routed_kinds_ = kinds
        return out

    def interval_method(self, kind: str) -> Any:
        """The estimator that gives route ``kind``'s interval (``"scan"``, ``"sparse"``, ``"points"`` or ``"map"``).

        The route's own method when it has ``predict_interval``; else ``intervals(name, method)``,
        made once (under the lock, as the routes are), around the route's method.

        Raises
        ------
        InvalidInputError
            If the route has no interval and ``intervals`` gives none: it is named, rather
            than a frame being given the other route's method and interval.
        """
        method = self._route(kind)
        if hasattr(method, "predict_interval"):
            return method
        made, name = f"_{kind}_interval", self.name_of(kind)
        if made not in self.__dict__:
            if self.intervals is None or kind == "points":  # no calibration is made on scattered points
                why = "none is calibrated on such scans" if kind == "points" else "ships none"
                raise InvalidInputError(
                    f"no calibrated interval for a single {_KIND_WORDS[kind]} yet: its route {name} {why}; drop the interval "
                    f"(fill without --confidence), or give one (--intervals CAL.json, or -m <method>-intervals)")
            with _MAKING:
                if made not in self.__dict__:
                    try:
                        self.__dict__[made] = self.intervals(name, method)
                    except InvalidInputError as exc:  # say which frames: the route's kind, not only its method
                        raise InvalidInputError(f"no calibrated interval for a {_KIND_WORDS[kind]} (route {name}): "
                                                f"{exc}") from None
        return self.__dict__[made]

    def predict(self, X: Any, return_std: bool = False) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """Fill each frame by its route; with ``return_std`` also each route's per-pixel std.

        Parameters
        ----------
        X : array-like
            ``(H, W)`` or ``(N, H, W)`` metres, NaN = fill, 0 = no measurement.
        return_std : bool, default False
            Also return ``std`` (scikit-learn's ``GaussianProcessRegressor`` convention),
            from each frame's :meth:`interval_method`.

        Returns
        -------
        pred : numpy.ndarray
            float32 metres, the same as ``predict(X)`` bit for bit.
        std : numpy.ndarray, only with ``return_std``
            float32 metres, 0 at measured pixels. For a conformal interval
            (:class:`~estimators.intervals.ConformalIntervalInpainter`) it is the half-width of
            the calibrated interval (nominal coverage ``c``, 0.9 for the shipped calibrations)
            divided by the normal quantile ``z_c`` (1.645 at 0.9): ``pred ± z_c · std`` is that
            interval. It assumes nothing is normal: ``pred ± z · std`` at another coverage is
            not calibrated (ask :meth:`predict_interval` for it).

        Raises
        ------
        InvalidInputError
            If a frame's route gives no interval (see :meth:`interval_method`).
        """
        if not return_std:
            return super().predict(X)
        check_is_fitted(self)
        x = check_inpaint_input(X)
        batch = x[None] if x.ndim == 2 else x
        kinds = [self.kind(frame) for frame in batch]
        pred, std = np.empty(batch.shape, np.float32), np.zeros(batch.shape, np.float32)
        for kind, pick, _ in self._routes(kinds):
            method = self.interval_method(kind)
            if "return_std" not in inspect.signature(method.predict).parameters:
                name = self.name_of(kind)
                raise InvalidInputError(f"the interval of route {name} ({type(method).__name__}) gives no std: ask "
                                        "predict_interval instead of predict(X, return_std=True)")
            pred[pick], std[pick] = method.predict(batch[pick], return_std=True)
        self.routed_to_ = [self.name_of(k) for k in kinds]
        self.routed_kinds_ = kinds
        pred = np.where(batch > 0, batch, pred)  # as predict: measured pixels are given
        return (pred[0], std[0]) if x.ndim == 2 else (pred, std)

    def predict_interval(self, X: Any, coverage: float = 0.9,
                         prediction: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Per-pixel ``(low, high)`` of nominal ``coverage``, each frame from the interval of its route.

        Parameters
        ----------
        X : array-like
            ``(H, W)`` or ``(N, H, W)`` metres, NaN = fill.
        coverage : float
            Nominal coverage in (0, 1).
        prediction : numpy.ndarray, optional
            This estimator's prediction of ``X``, handed on to a route that takes it.

        Raises
        ------
        InvalidInputError
            If a frame's route gives no interval (see :meth:`interval_method`).
        """
        x = np.asarray(X, dtype=np.float32)
        batch = x if x.ndim == 3 else x[None]
        kinds = [self.kind(frame) for frame in batch]
        low, high = np.empty(batch.shape, np.float32), np.empty(batch.shape, np.float32)
        for kind, pick, _ in self._routes(kinds):
            method = self.interval_method(kind)
            given = {}
            if prediction is not None and "prediction" in inspect.signature(method.predict_interval).parameters:
                given["prediction"] = (prediction if prediction.ndim == 3 else prediction[None])[pick]
            low[pick], high[pick] = method.predict_interval(batch[pick], coverage=coverage, **given)
        return (low, high) if x.ndim == 3 else (low[0], high[0])
