"""The interval calibrations shipped with the package (releases and classical fills), and loading a saved one by path."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from inpaintenv.exceptions import InvalidInputError

from ._conformal import ConformalIntervalInpainter

__all__ = ["default_intervals", "load_intervals", "release_intervals", "shipped_intervals"]


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
        have = ", ".join(shipped_intervals()) or "none"
        raise InvalidInputError(f"method {name!r} has no shipped interval calibration (shipped: {have}); calibrate "
                                "one with ConformalIntervalInpainter(...).fit on drives it never saw and save it")
    return path


def _calibrated_route(route: Any, name: str) -> ConformalIntervalInpainter:
    """A router's ``route`` (made now if it waits for first use) in the calibration shipped for ``name``."""
    from ..learned import OnFirstUse

    method = route.make() if isinstance(route, OnFirstUse) else route
    return ConformalIntervalInpainter.load(_calibration_path(name), estimator=method)


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


def default_intervals(name: str | None = None, input: str = "auto") -> Any:
    """``pretrained-intervals``: routed like ``pretrained`` (:func:`estimators.learned.load_default`),
    each route in its own shipped calibration.

    A map's interval is the map release's calibration; a single scan's is the calibration
    shipped for the scan route's method by its name (``<SCAN_DEFAULT>.json``, calibrated on
    scans), wrapped around the route's own method, so its fill is ``pretrained``'s bit for
    bit. A scan route without a shipped calibration gives no interval: asking it for a scan's
    is one error naming it, never the map release's fill and interval on a scan. As for
    ``pretrained``, each route is loaded when a frame first takes it.

    Parameters
    ----------
    name : str, optional
        The map release (the default release by default).
    input : {"auto", "scan", "map"}
        As for :func:`~estimators.learned.load_default`.
    """
    from inpaintenv.methods.learned import DEFAULT_RELEASE, SCAN_DEFAULT

    from ..learned import OnFirstUse, load_default

    map_name = name or DEFAULT_RELEASE
    _calibration_path(map_name)  # a release without a calibration is refused now, not at its first map
    routed = load_default(input=input)
    routed.map_method = OnFirstUse(release_intervals, map_name)
    routed.map_name = map_name
    if routed.scan_name == SCAN_DEFAULT and SCAN_DEFAULT in shipped_intervals():
        routed.scan_method = OnFirstUse(_calibrated_route, routed.get_params(deep=False)["scan_method"], SCAN_DEFAULT)
    return routed
