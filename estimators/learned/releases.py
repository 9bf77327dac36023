"""The shipped learned releases by name, whatever their class, and the default one.

A release is a checkpoint's two files under flat names in ``estimators/pretrained/``
(``NAME.safetensors``, ``NAME.json``); its JSON records the class, the parameters it was
trained with (its recipe: :func:`recipe`) and the drives it saw.

>>> from estimators.learned.releases import DEFAULT_RELEASE, load_release      # doctest: +SKIP
>>> est = load_release()                                                 # the default
>>> est = load_release("kitti-mixed-v1")                                 # any release by name
"""

from __future__ import annotations

from typing import Any

from . import _checkpoint as ckpt
from ._load import load

__all__ = ["DEFAULT_RELEASE", "SCAN_DEFAULT", "load_default", "load_release", "shipped"]

#: The release ``-m pretrained`` (alias ``blend-pretrained``) loads: the default learned
#: method of the benchmark (docs/model_card.md).
DEFAULT_RELEASE = ckpt.DEFAULT_RELEASE


#: What ``pretrained`` fills a single LiDAR scan with: the scan release, the classical mean
#: ``harmonic-ipbasic`` near the scan's measurements and a learned blend far from them (in a hole);
#: on both official sets with a scan it is no worse than every classical fill on densify and
#: better in rect-v1's holes (docs/model_cards/kitti-scan-v1.md).
SCAN_DEFAULT = "kitti-scan-v1"


def load_default(input: str = "auto", **overrides: Any) -> Any:
    """The default method ``pretrained``: the map release for a map, the scan release :data:`SCAN_DEFAULT` for a scan.

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
    """
    from ._routed import InputRoutedInpainter

    return InputRoutedInpainter(map_method=load_release(DEFAULT_RELEASE, **overrides),
                                scan_method=load_release(SCAN_DEFAULT), input=input, scan_name=SCAN_DEFAULT,
                                map_name=DEFAULT_RELEASE)


def shipped() -> dict[str, str]:
    """Every complete shipped release and the class it records."""
    return ckpt.shipped()


def load_release(name: str = DEFAULT_RELEASE, **overrides: Any) -> Any:
    """Load a shipped release by name (default :data:`DEFAULT_RELEASE`).

    Parameters
    ----------
    name : str
        Release name (see :func:`shipped`).
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
