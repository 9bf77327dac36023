"""``load_release`` and ``load_default``: the shipped learned releases by name, whatever their class.

A release is a checkpoint's two files under flat names in ``estimators/pretrained/``
(``NAME.safetensors``, ``NAME.json``); its JSON records the class, the parameters it was
trained with (its recipe: :func:`~estimators.learned.presets.recipe`) and the drives it saw.
The folder, the list of releases and the defaults are read from the torch-free
:mod:`inpaintenv.methods.learned` (``RELEASE_DIR``, ``shipped``, ``DEFAULT_RELEASE``,
``SCAN_DEFAULT``), which the method registry reads too.

>>> from estimators.learned import load_release                          # doctest: +SKIP
>>> est = load_release()                                                 # the default
>>> est = load_release("kitti-mixed-v1")                                 # any release by name
"""

from __future__ import annotations

from typing import Any

from inpaintenv.exceptions import UnknownNameError
from inpaintenv.methods.classical import CLASSICAL_METHODS
from inpaintenv.methods.learned import DEFAULT_RELEASE, POINTS_DEFAULT, SCAN_DEFAULT, SPARSE_DEFAULT, shipped

from . import _checkpoint as ckpt
from ._load import load

__all__ = ["load_default", "load_release"]


def load_default(input: str = "auto", **overrides: Any) -> Any:
    """The default method ``pretrained``: the map release for a map, the scan release :data:`~inpaintenv.methods.learned.SCAN_DEFAULT` for a scan.

    A scan sparser than a 64-beam one (:func:`~estimators.learned._routed.scan_spacing` above
    :data:`~estimators.learned._routed.SPARSE_SPACING`) goes to the sparse release
    :data:`~inpaintenv.methods.learned.SPARSE_DEFAULT` instead; a scan of points scattered far apart
    along its lines (:func:`~estimators.learned._routed.row_spacing` above
    :data:`~estimators.learned._routed.POINTS_SPACING`) to the classical
    :data:`~inpaintenv.methods.learned.POINTS_DEFAULT`.

    Parameters
    ----------
    input : {"auto", "scan", "map"}, default "auto"
        Every frame's kind, or ``"auto"``: each frame's from its measured density
        (:class:`~estimators.learned._routed.InputRoutedInpainter`).
    **overrides
        Prediction-time parameters of the map release (:func:`load_release`).

    Returns
    -------
    InputRoutedInpainter
        Its ``routed_to_`` names the method that filled each frame of the last ``predict``.
        Each release is loaded when its route first fills a frame (a run on scans never
        loads the map release); with ``overrides`` the map release is loaded at once, so a
        bad one is refused here.

    Raises
    ------
    KeyError
        A default release is not shipped (found here, not at the first frame).
    """
    from ._routed import InputRoutedInpainter, OnFirstUse

    releases = shipped()
    for name in (DEFAULT_RELEASE, SCAN_DEFAULT, SPARSE_DEFAULT):
        if name not in releases:
            raise UnknownNameError(f"no shipped release {name!r}; shipped: {sorted(releases)}")
    map_method = load_release(DEFAULT_RELEASE, **overrides) if overrides else OnFirstUse(load_release, DEFAULT_RELEASE)
    return InputRoutedInpainter(map_method=map_method, scan_method=OnFirstUse(load_release, SCAN_DEFAULT), input=input,
                                scan_name=SCAN_DEFAULT, map_name=DEFAULT_RELEASE,
                                sparse_method=OnFirstUse(load_release, SPARSE_DEFAULT), sparse_name=SPARSE_DEFAULT,
                                points_method=_classical(POINTS_DEFAULT), points_name=POINTS_DEFAULT)


def _classical(name: str) -> Any:
    """The classical fill registered as ``name`` (its row of :data:`~inpaintenv.methods.classical.CLASSICAL_METHODS`)."""
    import estimators.classical as classical

    (cls, kwargs), = [(cls, kwargs) for row, cls, kwargs, _ in CLASSICAL_METHODS if row == name]
    return getattr(classical, cls)(**kwargs)


def load_release(name: str = DEFAULT_RELEASE, **overrides: Any) -> Any:
    """Load a shipped release by name (default :data:`~inpaintenv.methods.learned.DEFAULT_RELEASE`).

    Parameters
    ----------
    name : str
        Release name (see :func:`inpaintenv.methods.learned.shipped`).
    **overrides
        Prediction-time parameters (e.g. ``tta``, ``predict_threads``; an ensemble member's
        as ``blend__tta``).

    Raises
    ------
    KeyError
        No release of that name is shipped (the message lists them).
    ValueError
        An override of a parameter the weights depend on.
    """
    with ckpt.release_folder(name) as folder:
        est = load(folder)
    return ckpt.with_overrides(est, name, overrides)
