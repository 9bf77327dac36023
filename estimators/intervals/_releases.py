"""The interval calibrations shipped with the package (releases and classical fills), and loading a saved one by path."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from inpaintenv.exceptions import InvalidInputError

from ._conformal import ConformalIntervalInpainter

__all__ = ["ROUTE_INTERVALS", "ShippedIntervals", "default_intervals", "load_intervals", "release_intervals",
           "shipped_intervals"]

#: Calibrations shipped for one route of ``pretrained`` only, by the route's method name ->
#: file stem in ``intervals/routes/``. Kept apart from the method calibrations so that none
#: registers ``<name>-intervals`` for maps: the sparse route's release is calibrated on
#: 32/16/8-beam scans only.
ROUTE_INTERVALS: dict[str, str] = {"kitti-sparse-v1": "sparse-kitti-sparse-v1"}


def _intervals_dir() -> Path:
    """``estimators/pretrained/intervals``: one calibration JSON per method that ships one."""
    return Path(__file__).resolve().parents[1] / "pretrained" / "intervals"


def shipped_intervals() -> list[str]:
    """The methods (releases and classical fills) shipped with an interval calibration (``release_intervals`` loads them)."""
    folder = _intervals_dir()
    return sorted(p.stem for p in folder.glob("*.json")) if folder.is_dir() else []


def release_intervals(name: str | None = None, **overrides: Any) -> ConformalIntervalInpainter:
    """A shipped release, or a classical fill, wrapped in its shipped interval calibration.

    Parameters
    ----------
    name : str, optional
        Release name (the default release, ``pretrained``, by default) or the name of a classical
        fill that ships a calibration (``shipped_intervals()`` lists them all).
    **overrides
        Prediction-time parameters of the release (see
        :func:`estimators.learned.load_release`) or parameters of the classical fill
        (``n_jobs``, ...).

    Returns
    -------
    ConformalIntervalInpainter
        ``predict`` is the method's, bit for bit; ``predict_interval`` and
        ``predict(X, return_std=True)`` use the calibration of
        ``estimators/pretrained/intervals/<name>.json`` (what it was calibrated on is in
        ``calibration_``; docs/model_card.md and docs/estimators.md, "Per-pixel intervals").

    Raises
    ------
    InvalidInputError
        When the method has no shipped calibration (the message lists those that have one).
    """
    from ._bases import CLASSICAL_FILLS, make_base

    if name is None:
        from inpaintenv.methods.learned import DEFAULT_RELEASE

        name = DEFAULT_RELEASE
    path = _calibration_path(name)
    if name in CLASSICAL_FILLS:
        base = make_base(name)
        if overrides:
            base.set_params(**overrides)
    else:
        from estimators.learned import load_release

        base = load_release(name, **overrides)
    return ConformalIntervalInpainter.load(path, estimator=base)


def _calibration_path(name: Any) -> Path:
    """The shipped calibration of method ``name``; one error listing those shipped if it has none."""
    path = _intervals_dir() / f"{name}.json" if isinstance(name, str) else None
    if path is None or not path.is_file():
        raise _no_calibration(name)
    return path


def _route_path(name: Any) -> Path:
    """A route's calibration: its own (:data:`ROUTE_INTERVALS`) if it ships one, else its method's."""
    stem = ROUTE_INTERVALS.get(name) if isinstance(name, str) else None
    path = _intervals_dir() / "routes" / f"{stem}.json" if stem else None
    if path is not None and path.is_file():
        return path
    if name not in shipped_intervals():  # only a shipped file's name, never a path
        raise _no_calibration(name)
    return _calibration_path(name)


def _no_calibration(name: Any) -> InvalidInputError:
    have = ", ".join(shipped_intervals()) or "none"
    return InvalidInputError(f"method {name!r} has no shipped interval calibration (shipped: {have}); calibrate "
                             "one with ConformalIntervalInpainter(...).fit on drives it never saw and save it")


def load_intervals(path: str | os.PathLike, estimator: Any = None) -> ConformalIntervalInpainter:
    """:meth:`ConformalIntervalInpainter.load` as a function (the registry's ``intervals`` method).

    Parameters
    ----------
    path : path-like
        A calibration written by :meth:`ConformalIntervalInpainter.save`.
    estimator : fitted inpainter, optional
        The base; rebuilt from the file's ``base`` by default.
    """
    return ConformalIntervalInpainter.load(path, estimator=estimator)


class ShippedIntervals:
    """The interval of a route of ``pretrained``: the calibration shipped for the route's name.

    ``ShippedIntervals()(name, method)`` is ``method`` wrapped in the route's own calibration
    (``intervals/routes/``, :data:`ROUTE_INTERVALS`: the sparse route's release) or else
    ``estimators/pretrained/intervals/<name>.json`` (a :class:`ConformalIntervalInpainter`,
    whose ``predict`` is ``method``'s bit for bit); the ``intervals`` of
    :class:`~estimators.learned.InputRoutedInpainter`. Stateless, so it pickles and copies.

    Raises
    ------
    InvalidInputError
        When called for a name that ships no calibration (the message lists those that do).
    """

    def __call__(self, name: str, method: Any) -> ConformalIntervalInpainter:
        return ConformalIntervalInpainter.load(_route_path(name), estimator=method)

    def __eq__(self, other: object) -> bool:
        return type(other) is ShippedIntervals

    def __hash__(self) -> int:
        return hash(ShippedIntervals)

    def __repr__(self) -> str:
        return "ShippedIntervals()"


def default_intervals(name: str | None = None, input: str = "auto", require_calibration: bool = True,
                      **overrides: Any) -> Any:
    """``pretrained`` and ``pretrained-intervals``: routed as :func:`estimators.learned.load_default`,
    each route's interval from the calibration shipped for its method by name.

    A map's interval is the map release's calibration (calibrated on maps); a single scan's
    (any frame routed as a 64-beam-like scan) the one shipped for the scan route
    (``<SCAN_DEFAULT>.json``, calibrated on scans), wrapped around the route's own method when
    an interval is first asked (:class:`ShippedIntervals`), so the fill is ``pretrained``'s
    bit for bit. A sparse scan's (32/16/8 beams: the sparse route's release) is the
    calibration shipped for that route only (:data:`ROUTE_INTERVALS`, calibrated on thinned
    scans). A route without a shipped calibration gives no interval: asking it is one error
    naming it, never another route's interval. Each route is loaded when a frame first
    takes it; its calibration when a frame's interval is first asked.

    Parameters
    ----------
    name : str, optional
        The map release (the default release by default).
    input : {"auto", "scan", "map"}
        As for :func:`~estimators.learned.load_default`.
    require_calibration : bool, default True
        Refuse now a map release that ships no calibration (``pretrained-intervals``);
        ``pretrained`` (False) fills without one and refuses only an interval asked of it.
    **overrides
        Prediction-time parameters of the map release (:func:`~estimators.learned.load_release`).

    Returns
    -------
    InputRoutedInpainter
        ``predict_interval(X, coverage)`` and ``predict(X, return_std=True)`` (``std``: the
        calibrated 90 % half-width over 1.645, see
        :meth:`ConformalIntervalInpainter.predict`) on maps and scans.
    """
    from inpaintenv.methods.learned import DEFAULT_RELEASE

    from ..learned import OnFirstUse, load_default, load_release

    map_name = name or DEFAULT_RELEASE
    if require_calibration:
        _calibration_path(map_name)  # a release without a calibration is refused now, not at its first map
    if map_name == DEFAULT_RELEASE:
        routed = load_default(input=input, **overrides)
    else:
        routed = load_default(input=input)
        routed.map_method = load_release(map_name, **overrides) if overrides else OnFirstUse(load_release, map_name)
        routed.map_name = map_name
    routed.intervals = ShippedIntervals()
    return routed
